"""``liff colmap`` and ``liff sfm``: COLMAP databases and reconstructions (filled in
once liff.colmap lands)."""


def add_parser(sub) -> None:
    pass

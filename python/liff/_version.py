"""liff's version (pyproject.toml's), here so that every layer can name it without
importing the package root (liff/__init__.py, the public facade above the layers)."""

__version__ = "0.1.0"

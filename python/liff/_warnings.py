"""Warning classes of liff (no heavy imports: ``import liff`` loads this module)."""


class LiffWarning(UserWarning):
    """Base class of the warnings liff issues about its input."""


class LensletSizeWarning(LiffWarning):
    """An ESLF image's detected lenslet size disagrees with one of the cues
    (:func:`liff.io.detect_lenslet_size`)."""

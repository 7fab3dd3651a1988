"""Warning classes of liff (no heavy imports: ``import liff`` loads this module)."""


class LiffWarning(UserWarning):
    """Base class of the warnings liff issues about its input."""


class IntensityWarning(LiffWarning):
    """A light field's values do not fill the range its dtype is read on (uint16 holding
    10- or 12-bit sensor data, floats in 0..255, ...): LiFF's thresholds would be off.
    See :func:`liff.io.check_intensity`."""


class LensletSizeWarning(LiffWarning):
    """An ESLF image's detected lenslet size disagrees with one of the cues
    (:func:`liff.io.detect_lenslet_size`)."""


class MissingViewsWarning(LiffWarning):
    """A light field's view set is incomplete: it is read as the whole grid with the
    missing views at weight (alpha) 0, and the message names them (docs/INPUTS.md)."""


class SlopeRangeWarning(LiffWarning):
    """More than 5% of the features sit at an end of a hand-set slope range, so the
    slopes of structure beyond it are pinned there; the message names the range the
    automatic survey finds (docs/SLOPES.md)."""

from typing import Optional, Sequence, Tuple, Union
import os

import cv2
import numpy as np

from . import _core

SLOPE_SCALE: float
__version__: str

def setNumThreads(nthreads: int) -> None: ...
def getNumThreads() -> int: ...
def opencvVersion() -> str: ...
def keypoint_slopes(keypoints: Sequence[cv2.KeyPoint]) -> np.ndarray: ...

class LiFF(_core.LiFF):
    @classmethod
    def create(
        cls,
        nfeatures: int = 0,
        nOctaveLayers: int = 3,
        contrastThreshold: float = 0.04,
        edgeThreshold: float = 10,
        sigma: float = 1.6,
        firstSlope: float = -1,
        lastSlope: float = 1,
        numSlopes: int = 0,
        descriptorType: int = ...,
        rootSift: bool = False,
    ) -> "LiFF": ...
    def detect(self, lf: np.ndarray, mask: Optional[np.ndarray] = None) -> Tuple[cv2.KeyPoint, ...]: ...
    def compute(
        self, lf: np.ndarray, keypoints: Sequence[cv2.KeyPoint], descriptors: None = None
    ) -> Tuple[Tuple[cv2.KeyPoint, ...], Optional[np.ndarray]]: ...
    def detectAndCompute(
        self,
        lf: np.ndarray,
        mask: Optional[np.ndarray] = None,
        descriptors: None = None,
        useProvidedKeypoints: bool = False,
    ) -> Tuple[Tuple[cv2.KeyPoint, ...], Optional[np.ndarray]]: ...
    def save(self, filename: Union[str, os.PathLike]) -> None: ...
    def write(self, fs: Union[str, os.PathLike, cv2.FileStorage], name: Optional[str] = None) -> None: ...
    def read(self, source: Union[str, os.PathLike, cv2.FileNode]) -> None: ...

def LiFF_create(
    nfeatures: int = 0,
    nOctaveLayers: int = 3,
    contrastThreshold: float = 0.04,
    edgeThreshold: float = 10,
    sigma: float = 1.6,
    firstSlope: float = -1,
    lastSlope: float = 1,
    numSlopes: int = 0,
    descriptorType: int = ...,
    rootSift: bool = False,
) -> LiFF: ...

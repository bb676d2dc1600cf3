"""Stand-ins for hardware the LeRobot recording test has no access to, registered with LeRobot
the way a third-party camera is (``CameraConfig.register_subclass``).

``pattern`` camera: a camera (no webcam on a test machine, and an OpenCV camera reading a video
file runs through the file at decoding speed and then fails) that makes each frame on request:
a 48×64 RGB image whose every pixel holds the number of frames read so far, modulo 256. It
stands in for the camera hardware only; LeRobot's own observation, image writer and video
encoding handle its frames as any camera's.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

from lerobot.cameras.camera import Camera
from lerobot.cameras.configs import CameraConfig


@CameraConfig.register_subclass("pattern")
@dataclass
class PatternCameraConfig(CameraConfig):
    fps: int = 30
    width: int = 64
    height: int = 48


class PatternCamera(Camera):
    def __init__(self, config: PatternCameraConfig):
        super().__init__(config)
        self.config = config
        self.frames = 0
        self.connected = False

    @property
    def is_connected(self) -> bool:
        return self.connected

    @staticmethod
    def find_cameras() -> list:
        return []

    def connect(self, warmup: bool = True) -> None:
        self.connected = True

    def read(self, color_mode: Any = None) -> np.ndarray:
        self.frames += 1
        return np.full((self.config.height, self.config.width, 3), self.frames % 256, dtype=np.uint8)

    def async_read(self, timeout_ms: float = 200) -> np.ndarray:
        return self.read()

    def read_latest(self, max_age_ms: int = 500) -> np.ndarray:
        return self.read()

    def disconnect(self) -> None:
        self.connected = False

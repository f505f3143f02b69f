"""MJCF models shipped with auv-twin (menagerie layout: one folder per model)."""

from __future__ import annotations

from pathlib import Path

MODELS_DIR = Path(__file__).resolve().parent
AUV_DIR = MODELS_DIR / "auv"

SCENES: dict[str, Path] = {
    "open_sea": AUV_DIR / "scene_open_sea.xml",
    "tank": AUV_DIR / "scene_tank.xml",
}

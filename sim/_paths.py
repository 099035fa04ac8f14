"""Where the data that ships with the project lives (``data/`` at the repository top)."""

from pathlib import Path

DATA_DIR = Path(__file__).resolve().parents[1] / "data"
VEHICLE_DIR = DATA_DIR / "vehicles"
PARAMS_DIR = DATA_DIR / "params"

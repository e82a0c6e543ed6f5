"""Write the shipped anatomical colons, trajectories/anatomy-*.csv, from their seeds (docs/anatomy.md).

    python docs/examples/make_anatomies.py
"""
from pathlib import Path

from bhr.model._anatomy import SHIPPED, anatomy_csv_text

folder = Path(__file__).resolve().parent.parent.parent / "trajectories"
for name, (seed, note) in SHIPPED.items():
    path = folder / f"{name}.csv"
    path.write_text(anatomy_csv_text(seed, note=note), encoding="utf-8")
    print(f"wrote {path}")

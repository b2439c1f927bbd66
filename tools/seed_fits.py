"""Write the fits hriplan ships (robots/fit_cache.SEEDS): the clearance sub-cells of the built-in
robots' mesh pairs (`mesh_clearance`, ~25 s of CPU on a machine that has not fitted them), so
that a first `hriplan plan` reads them instead of computing them.

Run: PYTHONPATH=src python tools/seed_fits.py
It fits them in an empty cache directory and gzips the files of the kinds below into SEEDS, with
the versions of the mesh package, pinocchio and coal they were fitted with (their names hold them); run
it again when a fit's rules, the mesh package or pinocchio/coal change (tests/robots/
test_fit_seeds.py fails until then: the shipped files no longer match).
"""

from __future__ import annotations

import gzip
import json
import os
import sys
import tempfile
from pathlib import Path

KINDS = ("clearance-fine",)
ROBOTS = ("ur5", "madar")


def main() -> None:
    with tempfile.TemporaryDirectory() as cache:
        os.environ["XDG_CACHE_HOME"] = cache
        from hriplan.robots import fit_cache
        from hriplan.robots.collision import CollisionChecker
        from hriplan.robots.model import load_robot

        for name in ROBOTS:
            CollisionChecker(load_robot(name))._ready()  # the build fits the robot's clearance tables
        fit_cache.SEEDS.mkdir(parents=True, exist_ok=True)
        for old in fit_cache.SEEDS.glob("*.json.gz"):
            old.unlink()
        (fit_cache.SEEDS / "versions.json").write_text(json.dumps(fit_cache.fit_versions()) + "\n")
        for path in sorted(Path(cache, "hriplan").glob("*.json")):
            if path.name.rsplit("-", 1)[0] in KINDS:
                (fit_cache.SEEDS / f"{path.name}.gz").write_bytes(gzip.compress(path.read_bytes(), mtime=0))
                print(f"wrote {fit_cache.SEEDS / path.name}.gz", file=sys.stderr)


if __name__ == "__main__":
    main()

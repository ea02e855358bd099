"""The pushed object: mass, rectangular footprint, friction, inertia."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from grasp_ctrl.config.toml_reader import Table, read_toml
from grasp_ctrl.numeric.gravity import GRAVITY_M_S2


@dataclass(frozen=True)
class PushedBox:
    mass_kg: float
    size_m: tuple[float, float]  # footprint (lx along the object x axis, ly)
    mu: float  # object-support friction coefficient
    izz_kgm2: float | None = None  # about the vertical axis through the centre of mass
    gravity: float = GRAVITY_M_S2

    @property
    def inertia(self) -> float:
        """I_zz; a uniform box of the footprint when not given."""
        if self.izz_kgm2 is not None:
            return self.izz_kgm2
        lx, ly = self.size_m
        return self.mass_kg * (lx * lx + ly * ly) / 12.0


def load_box(path: str | Path) -> PushedBox:
    """OBJECT.toml of docs/design.md 5.4: mass_kg, size_m = [lx, ly], mu; optional izz_kgm2, gravity."""
    t = Table(path, read_toml(path))
    t.unknown_keys({"mass_kg", "size_m", "mu", "izz_kgm2", "gravity", "name"})
    size = t.vector("size_m", 2, bound=10.0)
    if min(size) <= 0:
        raise t.fail("size_m", f"two positive lengths in metres (got {list(size)})")
    izz = t.float("izz_kgm2", None, lo=1e-12, hi=1e6) if t.has("izz_kgm2") else None
    return PushedBox(
        mass_kg=t.float("mass_kg", lo=1e-4, hi=1e4),
        size_m=(size[0], size[1]),
        mu=t.float("mu", lo=0.0, hi=10.0, lo_open=True),  # no friction: no force to estimate
        izz_kgm2=izz,
        gravity=t.float("gravity", GRAVITY_M_S2, lo=0.0, hi=100.0, lo_open=True),
    )

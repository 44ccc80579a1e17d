"""What ``cptbt run`` and ``cptbt serve`` share in what they write and print."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any


def fresh_folder(base: Path) -> Path:
    """``base``, or ``base-2``, ``base-3``... : the first that does not exist."""
    out, k = base, 1
    while out.exists():
        k += 1
        out = base.with_name(f"{base.name}-{k}")
    return out


def fmt(v: float | None, unit: str = "") -> str:
    """A measure to one decimal, or "—" when it does not exist (None or NaN)."""
    return "—" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.1f}{unit}"


def time_share(shares: dict[str, Any]) -> str:
    """``behaviour 12%, ...`` of a summary's ``time_share``; "none 0%" says nothing, left out."""
    return ", ".join(f"{k} {v:.0%}" for k, v in shares.items() if k != "none" or v >= 0.005)

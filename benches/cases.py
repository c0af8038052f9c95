"""The benchmark cases by name, in the order ``python -m benches`` runs them."""

from __future__ import annotations

from collections.abc import Callable

from accelcore.apps.bench import Context, Table
from benches import (
    bulk,
    closed_loop,
    diagnosis,
    end_to_end,
    kernels,
    memory,
    reading,
    validation,
)

CASES: dict[str, Callable[[Context], list[Table]]] = {
    "kernels": kernels.run,
    "reading": reading.run,
    "end_to_end": end_to_end.run,
    "diagnosis": diagnosis.run,
    "closed_loop": closed_loop.run,
    "bulk": bulk.run,
    "memory": memory.run,
    "validation": validation.run,
}

"""Two families that explain the data alike: the one with fewer parameters.

Profile A soaks only at its cold end, then ramps up and down at one rate: on its runs a
function of the temperature and a function of the rate can look the same. An offset
that grows with the square of the rate (a thermal gradient's stress, nobody named it)
was taken as a sixteen-piece function of temperature, a step between the soak and the
ramps (held-out cut 43.8 % on x against 41.1 % for a line of the rate with a knot at
0); the validation session ramps at 1.47 °C/min instead of 2.7, and the step carried the
faster ramp's offset into it: 2.04 -> 2.37 mg (0.86x) on both seeds. The selection
now takes, among families that cut the held-out error alike on every axis the best one
is accepted on (its per-block cut not beaten by the paired test), the one with fewer
parameters (a lag's searched time constant counted as one): 1.25-1.26 mg (1.62x),
which is the ideal of that model space (1.26 mg).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

import numpy as np
import pytest

from accelcore.simulate.chain import RunState, Stage


@dataclass(frozen=True)
class OffsetVsRateSquared:
    """Offset of (0.4, -0.3, 0.6) mg per (°C/min)² of the die's rate of change."""

    name: str = "offset_vs_rate_squared"
    stage: Stage = "response"

    def apply(self, state: RunState, rng: np.random.Generator) -> None:
        rate = np.gradient(state.die_temp_c, state.time_s) * 60.0
        mg = np.array([0.4, -0.3, 0.6]) * (rate**2)[:, None]
        state.output = state.output + mg / 1000.0 * state.truth.sensitivity_per_g


@pytest.mark.parametrize("seed", [1, 2])
def test_a_rate_effect_is_not_taken_for_a_step_in_temperature(bench: ModuleType, seed: int) -> None:
    case = bench.ValidationCase("offset vs rate squared", part=(OffsetVsRateSquared(),))
    out = bench.run_case(case, seed, 1.0)
    assert "offset vs temperature_c" not in out.added, out.added
    # Measured 1.62x; the rule for an effect outside the model space: never worse.
    assert out.diagnosed_mg < out.base_mg, (out.added, out.base_mg, out.diagnosed_mg)

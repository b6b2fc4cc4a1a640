"""UVNAV navigation filter: the 11-state extended Kalman filter of thesis ch. 6 (Neele 1993).

The face of ``engine.filter``: it re-exports the public names of the modules that hold them,
one concept each, so ``from engine.filter import kalman as kf`` keeps working.

- :mod:`engine.filter.params` — :class:`FilterParams`, the run parameters;
- :mod:`engine.filter.state` — named indices, :class:`FilterState`, the constructors and the
  only functions that edit the state vector;
- :mod:`engine.filter.model` — transition Φ, noise gain Γ, process noise Q, fix-error presets;
- :mod:`engine.filter.predict` — the time update;
- :mod:`engine.filter.measurements` — H and R of the LSE, sensor and raw-LOP rows;
- :mod:`engine.filter.update` — the measurement update and its innovation tests.

Everything is a pure function of immutable values: a :class:`FilterState` goes in, a new one
comes out.
"""

from __future__ import annotations

from engine.filter.measurements import (
    Measurement,
    lop_measurement,
    lse_measurement,
    nav_measurement,
    sensor_measurement,
    stack_measurements,
)
from engine.filter.model import (
    FIX_TAU_DECCA_S,
    FIX_TAU_GNSS_S,
    FIX_TAU_GPS_CA_S,
    FIX_TAU_GPS_P_S,
    FIX_WHITE_FLOOR,
    GPS_WHITE_SIGMA_M,
    derived_fix_model,
    discrete_noise,
    jacobian,
    noise_gain,
    process_noise,
    propagate_mean,
    state_transition,
    transition,
    van_loan,
)
from engine.filter.params import DEG, FilterParams, accel_variance, current_rate_variance
from engine.filter.predict import predict, predict_horizon, predict_step
from engine.filter.state import (
    IDEPS,
    IDPSI,
    IDV,
    IEPS,
    IPSI,
    IV,
    IVCX,
    IVCY,
    IX,
    IY,
    IZ,
    N_NAV,
    STATE_LABELS,
    FilterState,
    add_fix_states,
    fix_states_from_fix,
    inflate_fix_states,
    init_state,
    move_to_grid,
    replace_current,
    replace_position,
    restart_dr_states,
    restart_fix_states,
)
from engine.filter.update import (
    LS_MONITOR,
    LS_REJECT,
    FilterDivergence,
    LomTest,
    LsTest,
    UpdateResult,
    innovation_distance,
    lom_test,
    ls_test,
    update,
)

__all__ = [
    "DEG",
    "FIX_TAU_DECCA_S",
    "FIX_TAU_GNSS_S",
    "FIX_TAU_GPS_CA_S",
    "FIX_TAU_GPS_P_S",
    "FIX_WHITE_FLOOR",
    "GPS_WHITE_SIGMA_M",
    "IDEPS",
    "IDPSI",
    "IDV",
    "IEPS",
    "IPSI",
    "IV",
    "IVCX",
    "IVCY",
    "IX",
    "IY",
    "IZ",
    "LS_MONITOR",
    "LS_REJECT",
    "N_NAV",
    "STATE_LABELS",
    "FilterDivergence",
    "FilterParams",
    "FilterState",
    "LomTest",
    "LsTest",
    "Measurement",
    "UpdateResult",
    "accel_variance",
    "add_fix_states",
    "fix_states_from_fix",
    "current_rate_variance",
    "derived_fix_model",
    "discrete_noise",
    "innovation_distance",
    "init_state",
    "jacobian",
    "lom_test",
    "lop_measurement",
    "ls_test",
    "lse_measurement",
    "move_to_grid",
    "nav_measurement",
    "noise_gain",
    "predict",
    "predict_horizon",
    "predict_step",
    "process_noise",
    "propagate_mean",
    "replace_current",
    "replace_position",
    "restart_dr_states",
    "restart_fix_states",
    "inflate_fix_states",
    "sensor_measurement",
    "stack_measurements",
    "state_transition",
    "transition",
    "update",
    "van_loan",
]

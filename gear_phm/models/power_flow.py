"""Power-flow directions through a transmission: the one definition of their codes.

The paper's two load cases are named by where the power enters: an *opposing* load takes power
out of the load side while the motor feeds it in (efficiency eta_D, eq 10); an *aiding* load
feeds power in from the load side and the motor brakes it (eta_I, eq 12). The codes are the
numbers on the ``power_flow`` fields of docs/architecture.md.
"""
from __future__ import annotations

#: Both sides take power out: physically impossible, rejected and counted.
IMPOSSIBLE = -1
#: Zero speed or both powers inside the deadband: no efficiency is measured.
IDLE = 0
#: Motor feeds power in, load takes it out: eta_D = -P_l / P_m.
OPPOSING = 1
#: Load feeds power in, motor takes it out: eta_I = -P_m / P_l.
AIDING = 2
#: Both sides feed power in (eta_I < 0, u > 1): the drive is self-locking.
SELF_LOCKING = 3

POWER_FLOW_NAMES: dict[int, str] = {IMPOSSIBLE: 'impossible', IDLE: 'idle',
                                    OPPOSING: 'opposing', AIDING: 'aiding',
                                    SELF_LOCKING: 'self_locking'}

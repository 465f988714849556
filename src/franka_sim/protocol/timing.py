"""The FCI's clock: one control cycle is one millisecond.

libfranka counts time in these cycles (`message_id`, `Duration`), and the simulator's own time
*is* that count: one published RobotState, one physics step. Every module that converts cycles
to seconds (differences, rates, filters, the pacer's deadlines) takes the period from here.
"""

CYCLE_PERIOD = 1e-3  # s

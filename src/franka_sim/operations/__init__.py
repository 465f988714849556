"""The control operations, in one place: what each is (the table) and what it does.

table.py     one row per operation: name, HTTP method and path, arguments, effect, robot kinds
arm.py       an arm's operations (ArmOps): ground truth, reset, bodies, pushes, recording
base.py      the mobile base's (BaseOps): health, state
faults.py    the network-fault operations every robot has
values.py    arguments checked before anything changes
ports.py     what they ask of the simulator: a cycle-thread job, the driver
embedded.py  FrankaSim's async methods, made from the table

Nothing is imported here: the client (franka_sim.control) reads table.py alone, without numpy.
"""

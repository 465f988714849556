"""The Desk: the robot's web API (HTTPS, port 443 on the robot), as plain Python.

`state.py` is the Desk itself, a state machine without sockets or clocks (brakes, operating
mode, FCI, end-effector power, the control token, the Pilot's buttons); `users.py` who may
call it; `rest_api.py` and `legacy_api.py` the two dialects clients speak (FR3 system 5+ and
the older Desk), each a table of routes from a request to an answer; `certificate.py` the
self-signed certificate it serves. The HTTPS adapter is server/desk_server.py (docs/desk.md).
Nothing here is imported unless the Desk is served or asked about.
"""

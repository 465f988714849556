"""The kinds of event the taps queue for the writer (the tuple's first item), and their fields:

    SENT robot data wall | COMMAND robot command on_time n completed wall | LOST robot n filled
    wall | REJECTED robot reason source data wall | TCP robot service event data n completed wall
    | REPLY robot service data n wall | TOOL_STATE robot service data wall | CONTROL robot operation
    arguments status result n completed wall | POSES n qpos wall | REPEATED n wall | LOG wall
    level logger message | SKIPPED first last wall
"""

(SENT, COMMAND, LOST, REJECTED, TCP, REPLY, TOOL_STATE, CONTROL, POSES, REPEATED, LOG,
 SKIPPED) = range(12)

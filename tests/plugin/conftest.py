# project/ and recording_project/ are users' test projects that test_plugin.py and
# test_recording.py run in a pytest of their own.
collect_ignore = ["project", "recording_project"]

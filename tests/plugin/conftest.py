# project/ is a user's test project that test_plugin.py runs in a pytest of its own.
collect_ignore = ["project"]

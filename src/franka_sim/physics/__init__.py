"""Physics: the Backend protocol and its MuJoCo implementation (synchronous; one owner thread)."""

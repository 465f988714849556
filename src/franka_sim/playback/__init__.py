"""What is done with a recording (the format: franka_sim/recording/): replay it in a fresh
simulator and compare bit for bit (replay.py), draw it (plot.py, with timeline.py's marks of
what the client did), make a video of it (render.py)."""

from franka_sim.cli import main

main()

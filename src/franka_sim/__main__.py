from franka_sim.launch import main

main()

"""The FR3 description: the served URDF parsed into plain data, the Hand's reported figures,
and numpy kinematics over them (no MuJoCo here, so every layer can use it)."""

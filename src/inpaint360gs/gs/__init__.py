"""The 3D Gaussian model and its optimisation (3DGS, Kerbl et al. 2023; paper Sec. 3.1)."""

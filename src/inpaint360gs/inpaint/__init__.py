"""2D inpainting, recursive conditioning, depth-guided initialisation and 3D inpainting (paper Sec. 3.5)."""

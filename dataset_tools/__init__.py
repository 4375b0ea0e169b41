"""Dataset building for 360° inpainting: the synthetic benchmark generator and the capture builder."""

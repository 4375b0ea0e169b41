"""Reading and writing scenes, images, masks and Gaussians."""

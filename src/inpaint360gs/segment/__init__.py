"""Raw 2D masks per training view and their association into view-consistent object ids (paper Sec. 3.2)."""

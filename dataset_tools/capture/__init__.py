"""Building Inpaint360GS scene folders from raw captures: joint COLMAP with one shared camera,
undistortion, point-leak removal, unseen masks, validation and importers. See README.md here."""

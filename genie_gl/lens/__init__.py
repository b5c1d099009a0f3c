"""The lens: distortion maps, each pixel's own ray (exact ids through any lens) and the
resampling of pinhole views into the lens's image."""

"""Sensor placement: a genetic search for the camera discs that cover a layout's labelled
floor (paper §3.4.1), its bit-set fitness and compiled coverage loops."""

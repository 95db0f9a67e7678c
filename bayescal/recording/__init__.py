"""Layer 1, recordings: files to arrays. Tables (CSV, Parquet, NPZ) and ROS bags, units,
the sample grid with its gaps, the pad window of a flight log, static sections and poses,
column finders. Imports nothing of bayescal above it.

The public names are re-exported by :mod:`bayescal`; this package's modules are private.
"""

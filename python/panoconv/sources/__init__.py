"""Rig sources (`panoconv.RigSource` adapters) of public datasets: `pandaset`."""

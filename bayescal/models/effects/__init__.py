"""The effect catalogue of ../shared/DESIGN.md: one class per effect, each in its own file,
holding what the effect adds to the spectrum or the mean, its parameters with their units, its
simulator and its explanation. :mod:`._catalogue` registers the effects discovery searches.
"""

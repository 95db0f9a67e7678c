"""Layer 7, reports: results rendered as the JSON documents of the command line, text, figures,
the self-contained HTML page, and the files other tools read (Kalibr, MATLAB). Imports the
layers below it, nothing above.

The public names are re-exported by :mod:`bayescal`; this package's modules are private.
"""

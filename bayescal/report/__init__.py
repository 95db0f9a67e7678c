"""Layer 7, reports: results rendered as the JSON documents of the command line, text, figures,
the self-contained HTML page, and the files other tools read (Kalibr, MATLAB). Imports the
layers below it, nothing above.

One home each:

- a result kind has one document function (its command's JSON: :func:`._noise.noise_document`,
  :func:`._discovery.discovery_document`, :func:`._two_position.two_position_result`,
  :func:`._multi_position.multi_position_result`, :func:`._fleet.fleet_result`; a thermal
  calibration's document is its file, :meth:`~bayescal.ThermalCalibration.save`);
- the text a command prints and the pages read the typed result (a
  :class:`~bayescal.NoiseFit` in its :class:`._noise.NoiseAnalysis`, a
  :class:`~bayescal.Discovery` in its :class:`._discovery.Findings`, the calibrations, a
  :class:`~bayescal.FleetFit`), never the document; what two of them show that is not an
  attribute of the result is derived once, beside the document function;
- every figure is one function of :mod:`._figures`, drawn on its own Agg canvas (no global
  matplotlib state), used by the page and by ``bayescal discover --out``;
- numbers and units as HTML, and the pages' style, are :mod:`._format`'s.

The public names are re-exported by :mod:`bayescal`; this package's modules are private.
"""

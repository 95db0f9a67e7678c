"""Write the CSV recordings the tests feed to the command line."""

from collections.abc import Mapping

import numpy as np


def write_csv(path, columns: Mapping, fmt: str = "%.17g"):
    """Write ``columns`` (header name -> values, one column each) as a CSV file with a header
    row; returns ``path``. The default format round-trips every float exactly."""
    np.savetxt(
        path,
        np.column_stack([np.asarray(values) for values in columns.values()]),
        delimiter=",",
        header=",".join(columns),
        comments="",
        fmt=fmt,
    )
    return path

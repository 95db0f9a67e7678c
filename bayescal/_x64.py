"""JAX in double precision: bayescal turns on JAX's 64-bit mode, for the whole process.

The likelihoods sum hundreds of terms whose differences carry the information (a float32
Whittle sum loses the rate random walk), and JAX fixes an array's precision when the array is
made. So every module of bayescal that uses JAX imports this one first, and the first use of
such a name — ``bc.fit_noise``, ``bc.NoiseModel``, any command but ``--help`` and
``--classical-only`` readings; not ``import bayescal``, which loads nothing — sets
``jax_enable_x64`` for the process: the caller's own JAX code then makes float64 arrays by
default too. Code that wants float32 runs inside ``with jax.enable_x64(False):``; bayescal's
own computations refuse to run with the mode off (:func:`require_x64`) rather than compute in
float32. A ``JAX_ENABLE_X64`` environment variable asking for float32 is overridden, with a
warning.

Loading JAX here also turns on the caches of what bayescal compiles (:mod:`bayescal._caches`),
before JAX reads its settings.
"""

import os
import warnings

from ._caches import enable_caches

enable_caches()

import jax  # noqa: E402  (after the caches' settings, which JAX reads when imported)

from ._errors import InputError  # noqa: E402

if os.environ.get("JAX_ENABLE_X64", "").strip().lower() in ("0", "false", "no", "off"):
    warnings.warn(
        f"JAX_ENABLE_X64={os.environ['JAX_ENABLE_X64']} is overridden: bayescal turns on JAX's "
        "64-bit mode for the process (its likelihoods need float64)",
        stacklevel=2,
    )
jax.config.update("jax_enable_x64", True)


def require_x64() -> None:
    """Refuse to compute with JAX's 64-bit mode off (turned off after bayescal turned it on,
    or inside ``with jax.enable_x64(False):``): float32 would lose what the likelihoods
    measure, silently.

    Raises
    ------
    InputError
        The mode is off.
    """
    if not jax.config.jax_enable_x64:
        raise InputError(
            "JAX's 64-bit mode is off (jax_enable_x64 = False): bayescal's likelihoods need "
            "float64",
            fix="leave it on while bayescal computes; run code that wants float32 inside "
            "'with jax.enable_x64(False):'",
        )

"""Posteriors as ArviZ data (an xarray DataTree), with units in the attributes."""

import json
from importlib.metadata import version

import numpy as np

from ..models._terms import parameter_unit
from ._noise_posterior import NoisePosterior


def noise_datatree(fit: NoisePosterior, unit: str, *, channel: str, source: str):
    """posterior (chain = emcee walker), sample_stats, log_likelihood (one Whittle term per
    frequency bin and per segment mean, independent by construction, so usable for LOO /
    ELPD), observed_data (the binned periodogram and the block means the bias comes from)."""
    spectral, level = fit.problem.spectral, fit.problem.level
    n_bins = spectral.n_bins
    n_terms = fit.pointwise_log_likelihood.shape[-1]
    units = {name: parameter_unit(name, unit) for name in fit.draws}
    import arviz_base

    tree = arviz_base.from_dict(
        {
            "posterior": dict(fit.draws),
            "sample_stats": {"lp": fit.log_posterior},
            "log_likelihood": {"whittle": fit.pointwise_log_likelihood},
            "observed_data": {
                "periodogram_mean": spectral.power / spectral.count,
                "frequencies_per_bin": spectral.count,
                "mean_increment": spectral.mean_increment,
                "block_mean": level.block_mean,
            },
        },
        coords={
            "frequency_hz": spectral.frequency_hz,
            "term": np.arange(n_terms),
            "segment": np.arange(spectral.mean_increment.size),
            "block_time_s": level.block_time_s,
        },
        dims={
            "whittle": ["term"],
            "periodogram_mean": ["frequency_hz"],
            "frequencies_per_bin": ["frequency_hz"],
            "mean_increment": ["segment"],
            "block_mean": ["block_time_s"],
        },
        attrs={
            "/": {
                "bayescal_version": version("bayescal"),
                "inference_library": "emcee",
                "inference_library_version": version("emcee"),
                "channel": channel,
                "source": source,
                "unit": unit,
                "terms": ",".join(fit.terms),
                "prior": fit.problem.prior.description,
                "seed": fit.seed,
                "rate_hz": spectral.rate_hz,
                "diagnostics": json.dumps(fit.diagnostics.as_dict()),
                "log_likelihood_terms": f"{n_bins} frequency bins, then one mean-increment "
                "term per segment",
            }
        },
    )
    for name, unit_of_parameter in units.items():
        tree["posterior"][name].attrs["units"] = unit_of_parameter
    return tree

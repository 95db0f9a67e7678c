"""The catalogue's registry: every effect by its name, and the order discovery tries them in.

Adding an effect to discovery is its file in this folder and one entry in ``SEARCHED`` (or,
for an effect decided on the samples themselves, ``SAMPLE``).
"""

from .bias_instability import BiasInstability
from .bias_step import BiasStep
from .earth_rotation import EarthRotation
from .g_sensitivity import GSensitivity
from .gauss_markov import GaussMarkov
from .noise_burst import NoiseBurst
from .outliers import Outliers
from .output_filter import OutputFilter
from .quantization import Quantization
from .random_telegraph import RandomTelegraph
from .rate_ramp import RateRamp
from .rate_random_walk import RateRandomWalk
from .saturation import Saturation
from .sinusoid import Sinusoid
from .thermal_bias import ThermalBias
from .warmup_transient import WarmupTransient
from .white import White

SEARCHED = (
    BiasInstability,
    RateRandomWalk,
    GaussMarkov,
    RateRamp,
    Quantization,
    ThermalBias,
    WarmupTransient,
    Sinusoid,
    GSensitivity,
    BiasStep,
    RandomTelegraph,
)
"""The effects discovery proposes in each round, in this order."""
SAMPLE = (Saturation, NoiseBurst, Outliers)
"""Effects decided first, on the samples' distribution and the baseline's variance scan, in
this order."""
CATALOGUE = {
    effect.name: effect for effect in (White, OutputFilter, *SEARCHED, *SAMPLE, EarthRotation)
}
"""Every effect of ../shared/DESIGN.md's catalogue (and white noise), by name."""

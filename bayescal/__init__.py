"""bayescal: Bayesian uncertainty quantification of inertial sensors."""

import jax

jax.config.update("jax_enable_x64", True)

from ._allan import DeviationResult as DeviationResult  # noqa: E402
from ._allan import allan_deviation as allan_deviation  # noqa: E402
from ._allan import hadamard_deviation as hadamard_deviation  # noqa: E402
from ._allan import modified_allan_deviation as modified_allan_deviation  # noqa: E402
from ._classical import student_t_interval as student_t_interval  # noqa: E402
from ._edf import deviation_interval as deviation_interval  # noqa: E402
from ._edf import equivalent_degrees_of_freedom as equivalent_degrees_of_freedom  # noqa: E402
from ._edf import identify_noise_exponent as identify_noise_exponent  # noqa: E402
from ._errors import BayescalError as BayescalError  # noqa: E402
from ._errors import HealthCheckError as HealthCheckError  # noqa: E402
from ._errors import InputError as InputError  # noqa: E402

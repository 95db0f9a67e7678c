"""bayescal: Bayesian uncertainty quantification of inertial sensors.

The public names, loaded on first use (Scientific Python SPEC 1, lazy loading): ``import
bayescal`` costs nothing, and a name pulls in only what it needs — the command line answers
``--help`` without importing JAX. The package is layered, each layer importing only those
before it: recording -> classical -> models -> navigation -> inference -> capabilities -> report
-> cli.
"""

import importlib

_EXPORTS = {
    # errors
    "BayescalError": "_errors",
    "InputError": "_errors",
    "HealthCheckError": "_errors",
    # recordings
    "load_recording": "recording._recording",
    "Recording": "recording._recording",
    "Channel": "recording._recording",
    "stream_channel": "recording._stream",
    "is_long_recording": "recording._stream",
    "SpooledSeries": "recording._series",
    "find_pad_window": "recording._pad",
    "PadWindow": "recording._pad",
    "find_static_sections": "recording._sections",
    "StaticSection": "recording._sections",
    "sensor_cards": "recording._sensor_cards",
    "find_card": "recording._sensor_cards",
    "SensorCard": "recording._sensor_cards",
    "read_manifest": "recording._manifest",
    "Manifest": "recording._manifest",
    # classical estimators
    "allan_deviation": "classical._allan",
    "modified_allan_deviation": "classical._allan",
    "hadamard_deviation": "classical._allan",
    "DeviationResult": "classical._allan",
    "deviation_interval": "classical._edf",
    "equivalent_degrees_of_freedom": "classical._edf",
    "identify_noise_exponent": "classical._edf",
    "student_t_interval": "classical._noise",
    "classical_noise": "classical._noise",
    "ClassicalNoise": "classical._noise",
    "SlopeReading": "classical._noise",
    "local_gravity": "classical._gravity",
    "LocalGravity": "classical._gravity",
    "Section": "classical._two_position",
    "Poses": "classical._multi_position",
    # models
    "NoiseModel": "models._noise_model",
    "FleetPopulation": "models._population",
    # navigation
    "simulate_park": "navigation._simulate",
    "ParkSimulation": "navigation._simulate",
    "Taxi": "navigation._simulate",
    # inference
    "Sampler": "inference._sampler",
    "FitCheck": "inference._checks",
    # capabilities
    "fit_noise": "capabilities._noise",
    "NoiseFit": "capabilities._noise",
    "calibrate_two_position": "capabilities._two_position",
    "TwoPositionCalibration": "capabilities._two_position",
    "calibrate_multi_position": "capabilities._multi_position",
    "MultiPositionCalibration": "capabilities._multi_position",
    "fit_thermal": "capabilities._thermal_fit",
    "ThermalCalibration": "capabilities._thermal",
    "load_thermal_calibration": "capabilities._thermal",
    "save_thermal_calibrations": "capabilities._thermal",
    "infield_update": "capabilities._infield",
    "InFieldUpdate": "capabilities._infield",
    "discover": "capabilities._discovery",
    "Discovery": "capabilities._discovery",
    "FoundEffect": "capabilities._discovery",
    "CheckResult": "capabilities._discovery",
    "plan_recording": "capabilities._plan",
    "RecordingPlan": "capabilities._plan",
    "filter_noise": "capabilities._filter_noise",
    "FilterNoise": "capabilities._filter_noise",
    "Aiding": "navigation._aiding",
    "within_spec": "capabilities._within_spec",
    "SpecCheck": "capabilities._within_spec",
    "fit_fleet": "capabilities._fleet",
    "FleetFit": "capabilities._fleet",
}

__all__ = sorted(_EXPORTS)  # noqa: PLE0605 (the one table above lists the public names)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'bayescal' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__

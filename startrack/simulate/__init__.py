"""Simulated frames: what the camera sees at an attitude (scene), the sensor, the rendered CCD
frame and its noise, the optics, colour, detector and space effects, attitude
trajectories, and the TOML presets.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "add_false_stars", "Band", "catalog_bv", "config_from_dict", "constant_rate",
    "DEFAULT_CONFIG", "deposit_gaussians", "Detector", "digitise", "documented", "Effects",
    "Environment", "FrameOptions", "LEO_FLUX", "load_config", "observe", "Optics",
    "REFERENCE_BV", "REFERENCE_C", "render_expected", "render_frame", "render_stars",
    "SAA_FLUX", "Scene", "SensorModel", "SimConfig", "simulation_trajectory", "TABLES",
    "Trajectory",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "add_false_stars": "_scene",
    "Band": "_colour",
    "catalog_bv": "_colour_catalog",
    "config_from_dict": "_config",
    "constant_rate": "_trajectory",
    "DEFAULT_CONFIG": "_config",
    "deposit_gaussians": "_render",
    "Detector": "_detector",
    "digitise": "_render",
    "documented": "_effect_table",
    "Effects": "_effects",
    "Environment": "_environment",
    "FrameOptions": "_config",
    "LEO_FLUX": "_environment",
    "load_config": "_config",
    "observe": "_scene",
    "Optics": "_optics",
    "REFERENCE_BV": "_colour",
    "REFERENCE_C": "_detector",
    "render_expected": "_render",
    "render_frame": "_render",
    "render_stars": "_render",
    "SAA_FLUX": "_environment",
    "Scene": "_scene",
    "SensorModel": "_sensor",
    "SimConfig": "_config",
    "simulation_trajectory": "_trajectory",
    "TABLES": "_effects",
    "Trajectory": "_trajectory",
})

"""Simulated frames: what the camera sees at an attitude (scene), the sensor, the rendered CCD
frame and its noise, the optics, colour, detector and space effects, attitude
trajectories, and the TOML presets.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "Effects", "Scene", "SensorModel", "SimConfig", "Trajectory", "load_config", "observe",
    "render_frame",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "Effects": "_effects",
    "Scene": "_scene",
    "SensorModel": "_sensor",
    "SimConfig": "_config",
    "Trajectory": "_trajectory",
    "load_config": "_config",
    "observe": "_scene",
    "render_frame": "_render",
})

"""Simulated frames: what the camera sees at an attitude (scene), the sensor, the rendered CCD
frame and its noise, attitude trajectories, and the TOML presets.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "Scene", "SensorModel", "SimConfig", "Trajectory", "load_config", "observe",
    "render_frame",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "Scene": "_scene",
    "SensorModel": "_sensor",
    "SimConfig": "_config",
    "Trajectory": "_trajectory",
    "load_config": "_config",
    "observe": "_scene",
    "render_frame": "_render",
})

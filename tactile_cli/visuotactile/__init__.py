"""The visuotactile chain of paper 002 (DIGIT, GelSight): surface normals from colour,
height maps, tactile meshes, the slip signal and the slip-avoidance monitor.

Public names are re-exported below as the modules land (one line per name).
"""

__all__: list[str] = []

"""The CPU renderer: Embree camera rays, then the NumPy reference shading (patchlight.shading)."""
from .camera import Camera
from .renderer import Renderer, RenderResult
from .settings import target_settings
from .target import Target

__all__ = ["Camera", "RenderResult", "Renderer", "Target", "target_settings"]

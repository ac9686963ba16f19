"""Show a solved design: 3D files, a headless picture, a self-contained browser viewer.

`render(result, path, ...)` picks the format from the suffix (.glb .obj .stl
.png .html). The scene (scene.py) is built once from the solution; picture.py
draws it with the numpy rasteriser in raster.py; viewer.py embeds it in a page.
"""

from __future__ import annotations

from fabhal.render.scene import FORMATS, RenderOptions, render

__all__ = ["FORMATS", "RenderOptions", "render"]

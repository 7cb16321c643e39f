"""flank_addon: 5-axis flank-milling planner for helical surfaces (pure numpy/scipy).

Importable standalone (``python -m flank_addon``) and inside Blender as a
subpackage of the ``flank_toolpath`` extension.  Never imports bpy.
"""
__version__ = "0.1.0"

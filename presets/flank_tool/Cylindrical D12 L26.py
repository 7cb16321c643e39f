# Flank Toolpath tool preset (Tool panel > Tool Presets): cylindrical (square) end mill, diameter 12, flute
# length 26, shank diameter 12, overall length 83 mm (short series).
# Dimensions in mm and degrees: the *_mm / *_deg settings convert them to the scene's unit (a unit-less
# scene counts as mm), so the tool has the same size whatever the unit and unit scale.
import bpy
settings = bpy.context.scene.flank_settings

settings.tool_kind = 'CYLINDER'
settings.tool_tip_diameter_mm = 12
settings.tool_flute_length_mm = 26
settings.tool_shank_diameter_mm = 12
settings.tool_shank_length_mm = 57

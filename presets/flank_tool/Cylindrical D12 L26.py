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
# Cutting data (finishing in steel, the core's PRESET_CUTTING_DATA): flutes, cutting speed m/min, feed per
# tooth mm, the tool's top spindle speed 1/min.
settings.tool_flutes = 4
settings.tool_cutting_speed_m_min = 120.0
settings.tool_feed_per_tooth_mm = 0.05
settings.tool_max_rpm = 12000.0

"""Plans: a building's floor plan turned into the wall points the localizer aligns scans to.

A plan arrives as an image, a ROS map_server map, a HouseExpo outline or a drawing (DXF, PDF, SVG,
IFC), and becomes a `PlanMap`: wall-surface points in metres in the map frame, with their
nearest-wall index. `plan_map` holds `PlanMap` (and `CacheSetting`); `plan_raster` the wall pixels
of an image (`PlanRaster`, `resolution_from_pixels`) and the points on their surfaces;
`wall_extraction` the walls of a raster drawing told from its text, symbols, door swings,
hatching and fills (`WallExtraction`, `extract_walls`); `ros_map`
map_server YAML + image (`RosMap`, `read_ros_map`, `write_ros_map`); `vector_plan` wall segments
from HouseExpo JSON and DXF and their sampling into points; `image_files` the header checks that
bound an image before it is decoded; `plan_cache` the on-disk cache of prepared plans;
`wall_index_stats` the sizes `PlanMap.prepare_index` reports (`WallIndexStats`); `plan_loading` one
plan from whatever file the command line is given (`load_plan`, `read_plan_file`, `plan_layers`);
`plan_formats` which format a file is and which optional extra reads it; the drawing readers
`dxf_plan`, `pdf_plan`, `svg_plan` and `ifc_plan` (with `step_file`, the STEP text IFC is written
in, and `region_outline`, the outline of wall areas less openings); `print_scale` print scales as
drawings write them; `plan_scaling` a plan scaled about its origin (`PlanMap.scaled`);
`scale_text` the scale from room labels (dimensions, areas) and `label_scale` from labels and the
rooms they sit in, their doors closed; `drawing_text` a raster drawing's text read by OCR (RapidOCR,
installed by hand) and `raster_scale` a raster's scale from it; `default_plan` the office
plan shipped in `planicp/data`; `plan_figure` the figure of the extracted points over the plan,
and of a drawing's wall extraction over the drawing. The public names are exported by `planicp`
itself; import them from there.
"""

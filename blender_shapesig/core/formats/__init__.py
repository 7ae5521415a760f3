"""bpy-free readers and validators of clip files: ``acclaim`` (ASF skeletons ``asf``, AMC motions ``amc``),
``bvh`` (BVH text decoding and validation before Blender's importer) and ``blend`` (.blend structure
validation before Blender's reader). The Blender half of reading is ``blender_shapesig.readers``."""

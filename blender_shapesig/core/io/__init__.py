"""Where clips come from, without Blender: ``sources`` (the front door: clip names, discovery, cache keys, the
reader registry) and the file formats: ``asf``/``amc``/``acclaim`` (Acclaim), ``bvh``, ``blend_file`` (.blend
validation before the Blender reader), ``bone_map_file`` (saved bone maps) and ``text`` (decoding, finite
numbers). The Blender half of reading is
``blender_shapesig.readers``."""

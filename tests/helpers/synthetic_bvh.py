"""A small BVH file that exercises the naming and parsing rules of the readers (``SYNTHETIC``, its text), shared by
the reader's test (tests/core/io/test_bvh_reader.py) and its comparison with Blender's importer
(tests/blender/readers/test_bvh_reader_vs_importer.py)."""

# spaces in a name, a repeated name, a joint without channels, an End Site, X-Y-Z and Y-X-Z orders, a root with
# positions in another order, CR LF line ends, more data lines than "Frames:" (the importer reads them all)
SYNTHETIC = """HIERARCHY\r
ROOT Hips\r
{\r
  OFFSET 0 0 0\r
  CHANNELS 6 Zposition Xposition Yposition Zrotation Yrotation Xrotation\r
  JOINT Left Leg\r
  {\r
    OFFSET 1 0 0\r
    CHANNELS 3 Xrotation Yrotation Zrotation\r
    JOINT Foot\r
    {\r
      OFFSET 0 -1 0\r
      End Site\r
      {\r
        OFFSET 0 -0.5 0\r
      }\r
    }\r
  }\r
  JOINT Foot\r
  {\r
    OFFSET -1 0 0\r
    CHANNELS 3 Yrotation Xrotation Zrotation\r
    End Site\r
    {\r
      OFFSET 0 -1 0\r
    }\r
  }\r
}\r
MOTION\r
Frames: 2\r
Frame Time: 0.0333333\r
1 2 3 10 20 30 -40 50 60 70 -80 90\r
4 5 6 -100 120 170 5 -5 15 179 89 -179\r
7 8 9 1 2 3 4 5 6 7 8 9\r
"""

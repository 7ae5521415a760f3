"""The panel's search (Blender layer): the scene's search library and its preconditions (``library``; which of the
file's actions meet an armature's: ``rig_library``), one Find Similar click in steps (``rank_job``), its rows in the
window manager's results (``result_rows``), their pictures (``thumbnails``) and what an animator does with a row:
Assign, Preview, Stop, Why (``results``). Indexing and ranking are ``core.search``'s; ``operators/search.py`` and
``panels/search.py`` stay thin above this. This file imports none of them: import the module you need. See
docs/dev/blender_layer.md.
"""

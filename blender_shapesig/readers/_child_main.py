"""The reading child process (``readers.child``): reads clip files one request at a time until its input ends, so
one start-up of Blender serves a whole folder, and a file that crashes an importer ends only this process. Run by
this Python with the bpy module or by the Blender binary in background mode, with one JSON argument (where the
package is); a request is one JSON line on stdin (``{"reader", "args", "out"}``), the clips (or the one-line error)
go to the .npz ``out`` (``_blend_file_child.write_result``) and a line ``PREFIX done OUT`` on the original stdout
says so. Whatever the importers print goes to stderr. The protocol: docs/dev/blender_layer.md.
"""

import importlib
import json
import os
import sys

PREFIX = b"\x1eshapesig-child:"
# reader name -> (module under the package, function); the function takes the request's "args" as keywords
READERS = {"interchange": ("readers.interchange", "read_interchange_here"),
           "blend": ("readers.blend_file", "read_blend_here")}


def serve(package, requests, reply):
    """Answer each request line of ``requests`` (bytes lines) with ``reply(bytes)`` once its result is written."""
    errors = importlib.import_module(f"{package}.core.errors")
    write_result = importlib.import_module(f"{package}.readers._blend_file_child").write_result
    for raw in requests:
        if not raw.strip():
            continue
        req = json.loads(raw)
        module, function = READERS[req["reader"]]
        try:
            reader = getattr(importlib.import_module(f"{package}.{module}"), function)
            write_result(req["out"], clips=reader(**req["args"]))
        except errors.ShapeSigError as exc:
            write_result(req["out"], error=exc)
        except Exception as exc:  # noqa: BLE001 - any failure of an importer is one line for this file
            write_result(req["out"], error=errors.ParseError(f"could not read the file ({errors.error_line(exc)})",
                                                             req["args"].get("path")))
        reply(PREFIX + b"done " + req["out"].encode() + b"\n")


def main(argv):
    args = json.loads(argv[-1])
    sys.path.append(args["package_dir"])  # the package, whose one-shot child does the rest of a child's start
    importlib.import_module(f"{args['package']}.readers._blend_file_child").boot(args)
    proto = os.fdopen(os.dup(1), "wb", buffering=0)  # the replies; fd 1 itself now goes to stderr
    os.dup2(2, 1)
    sys.stdout = sys.stderr

    def reply(line):
        proto.write(line)

    reply(PREFIX + b"ready\n")
    serve(args["package"], sys.stdin.buffer, reply)


if __name__ == "__main__":
    main(sys.argv)

#!/usr/bin/env python3
"""Writes the malformed-PLY corpus used by tests/ply_malformed.rs (run from this folder).

Each file is small and broken in one way; tests/ply_malformed.rs lists the phrase the error
message must contain for each.
"""
import struct

XYZ = "property float x\nproperty float y\nproperty float z\n"


def hdr(fmt, body):
    return f"ply\nformat {fmt} 1.0\n{body}end_header\n".encode()


def le_points(pts):
    return b"".join(struct.pack("<3f", *p) for p in pts)


TRI = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
files = {
    "empty.ply": b"",
    "bad_magic.ply": b"plx\nformat ascii 1.0\nelement vertex 0\n" + XYZ.encode() + b"end_header\n",
    "binary_garbage.ply": bytes(range(256)) * 2,
    "missing_end_header.ply": b"ply\nformat ascii 1.0\nelement vertex 1\n" + XYZ.encode() + b"0 0 0\n",
    "unknown_format.ply": hdr("binary_middle_endian", "element vertex 1\n" + XYZ) + b"0 0 0\n",
    "bad_version.ply": b"ply\nformat ascii 2.0\nelement vertex 1\n" + XYZ.encode() + b"end_header\n0 0 0\n",
    "no_format.ply": b"ply\nelement vertex 1\n" + XYZ.encode() + b"end_header\n0 0 0\n",
    "unknown_keyword.ply": hdr("ascii", "element vertex 1\n" + XYZ + "propety float w\n") + b"0 0 0\n",
    "unknown_type.ply": hdr("ascii", "element vertex 1\nproperty float x\nproperty float y\nproperty real z\n")
    + b"0 0 0\n",
    "bad_element_count.ply": hdr("ascii", "element vertex -5\n" + XYZ) + b"0 0 0\n",
    "duplicate_element.ply": hdr("ascii", "element vertex 1\n" + XYZ + "element vertex 1\n" + XYZ)
    + b"0 0 0\n0 0 0\n",
    "property_before_element.ply": hdr("ascii", "property float x\nelement vertex 1\n" + XYZ) + b"0 0 0\n",
    "no_vertex_element.ply": hdr("ascii", "element point 1\n" + XYZ) + b"0 0 0\n",
    "missing_z.ply": hdr("ascii", "element vertex 1\nproperty float x\nproperty float y\n") + b"0 0\n",
    "int_xyz.ply": hdr("binary_little_endian", "element vertex 1\nproperty int x\nproperty int y\nproperty int z\n")
    + struct.pack("<3i", 1, 2, 3),
    "truncated_binary.ply": hdr("binary_little_endian", "element vertex 3\n" + XYZ) + le_points(TRI)[:-5],
    "truncated_ascii.ply": hdr("ascii", "element vertex 3\n" + XYZ) + b"0.000 0.000 0.000\n1.000 0.000 0.000\n0.000 1.000",
    "bad_ascii_number.ply": hdr("ascii", "element vertex 2\n" + XYZ) + b"0 0 0\n1 0 zero\n",
    "face_index_out_of_range.ply": hdr(
        "binary_little_endian", "element vertex 3\n" + XYZ + "element face 1\nproperty list uchar int vertex_indices\n"
    )
    + le_points(TRI)
    + struct.pack("<B3i", 3, 0, 1, 7),
    "face_negative_index.ply": hdr(
        "ascii", "element vertex 3\n" + XYZ + "element face 1\nproperty list uchar int vertex_indices\n"
    )
    + b"0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
    "face_two_indices.ply": hdr(
        "ascii", "element vertex 3\n" + XYZ + "element face 1\nproperty list uchar int vertex_indices\n"
    )
    + b"0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
    "list_length_negative.ply": hdr(
        "binary_little_endian", "element vertex 3\n" + XYZ + "element face 1\nproperty list char int vertex_indices\n"
    )
    + le_points(TRI)
    + struct.pack("<b3i", -3, 0, 1, 2),
    "list_length_too_long.ply": hdr(
        "binary_little_endian",
        "element vertex 3\n" + XYZ + "element face 1\nproperty list uint int vertex_indices\n",
    )
    + le_points(TRI)
    + struct.pack("<I3i", 4_000_000_000, 0, 1, 2),
    "list_float_count.ply": hdr(
        "ascii", "element vertex 3\n" + XYZ + "element face 1\nproperty list float int vertex_indices\n"
    )
    + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    "face_float_indices.ply": hdr(
        "ascii", "element vertex 3\n" + XYZ + "element face 1\nproperty list uchar float vertex_indices\n"
    )
    + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    "face_before_vertex.ply": hdr(
        "ascii", "element face 1\nproperty list uchar int vertex_indices\nelement vertex 3\n" + XYZ
    )
    + b"3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n",
    "truncated_faces_binary.ply": hdr(
        "binary_little_endian", "element vertex 3\n" + XYZ + "element face 2\nproperty list uchar int vertex_indices\n"
    )
    + le_points(TRI)
    + struct.pack("<B3iB2i", 3, 0, 1, 2, 3, 2, 1),
    "truncated_faces_ascii.ply": hdr(
        "ascii", "element vertex 3\n" + XYZ + "element face 2\nproperty list uchar int vertex_indices\n"
    )
    + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 2 1\n",
    "oversized_faces.ply": hdr(
        "binary_little_endian", "element vertex 3\n" + XYZ + "element face 100000000\nproperty list uchar int vertex_indices\n"
    )
    + le_points(TRI)
    + struct.pack("<B3i", 3, 0, 1, 2),
    "oversized_count_ascii.ply": hdr("ascii", "element vertex 100000000\n" + XYZ) + b"0 0 0\n1 0 0\n0 1 0\n",
}

# Header claims 10^12 vertices; the whole file is exactly 200 bytes.
big = hdr("binary_little_endian", "element vertex 1000000000000\n" + XYZ)
files["oversized_count.ply"] = big + bytes(200 - len(big))
# 10^8 vertices (2.4 GB as f64 points) claimed by a 200-byte file: run under a memory limit in
# the test, so allocating by the header's count would abort the process.
mid = hdr("binary_little_endian", "element vertex 100000000\n" + XYZ)
files["oversized_count_1e8.ply"] = mid + bytes(200 - len(mid))

for name, data in files.items():
    with open(name, "wb") as f:
        f.write(data)
print(len(files), "files")

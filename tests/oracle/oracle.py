"""Long-lived oracle process for camsim's differential tests.

The Rust tests (tests/src/oracle.rs) start this once per test binary and send requests over
stdin; replies come back on stdout. Framing, both ways:

    u32 little-endian length of a JSON header, the header, then the raw little-endian bytes of
    each array the header lists as {"dtype": "f64"|"f32"|"u16"|"u8", "shape": [...]}.

Request header: {"op": NAME, "args": {...}, "arrays": [...]}.
Reply header:   {"ok": true, "values": {...}, "arrays": [...]} or {"ok": false, "error": TEXT}.

Each op calls one reference implementation (OpenCV, colour-science, colour-demosaicing) and
nothing else, so a disagreement points at camsim, not at glue code here.
"""

import importlib.metadata
import json
import struct
import pathlib
import sys
import traceback
import warnings

import numpy as np

DTYPES = {"f64": "<f8", "f32": "<f4", "u16": "<u2", "u8": "u1"}
NAMES = {np.dtype(v).str: k for k, v in DTYPES.items()}


def read_exact(stream, n):
    data = bytearray()
    while len(data) < n:
        chunk = stream.read(n - len(data))
        if not chunk:
            raise EOFError
        data.extend(chunk)
    return bytes(data)


def read_message(stream):
    (length,) = struct.unpack("<I", read_exact(stream, 4))
    header = json.loads(read_exact(stream, length))
    arrays = []
    for spec in header.get("arrays", []):
        dtype = np.dtype(DTYPES[spec["dtype"]])
        shape = tuple(spec["shape"])
        count = int(np.prod(shape, dtype=np.int64)) if shape else 1
        raw = read_exact(stream, count * dtype.itemsize)
        arrays.append(np.frombuffer(raw, dtype=dtype).reshape(shape))
    return header, arrays


def write_message(stream, header, arrays=()):
    specs, blobs = [], []
    for a in arrays:
        a = np.ascontiguousarray(a)
        if a.dtype.str not in NAMES:
            a = a.astype("<f8")
        specs.append({"dtype": NAMES[a.dtype.str], "shape": list(a.shape)})
        blobs.append(a.tobytes())
    header = dict(header, arrays=specs)
    body = json.dumps(header).encode()
    stream.write(struct.pack("<I", len(body)) + body)
    for b in blobs:
        stream.write(b)
    stream.flush()


def op_ping(args, arrays):
    import colour
    import colour_demosaicing
    import cv2
    import rawpy

    versions = {
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "opencv": cv2.__version__,
        "colour-science": colour.__version__,
        "colour-demosaicing": colour_demosaicing.__version__,
        "rawpy": rawpy.__version__,
        # Imported only by the DNG colour op (it is slow to import); its version from metadata.
        "colour-hdri": importlib.metadata.version("colour-hdri"),
    }
    return {"versions": versions}, []


def op_srgb_encode(args, arrays):
    import colour

    return {}, [colour.models.eotf_inverse_sRGB(arrays[0])]


def op_srgb_decode(args, arrays):
    import colour

    return {}, [colour.models.eotf_sRGB(arrays[0])]


def op_srgb_matrices(args, arrays):
    import colour

    space = colour.RGB_COLOURSPACES["sRGB"]
    return {}, [space.matrix_XYZ_to_RGB, space.matrix_RGB_to_XYZ]


def op_bradford(args, arrays):
    """arrays: XYZ (N,3), source white XYZ (3,), target white XYZ (3,)."""
    import colour

    xyz, src, dst = arrays
    out = colour.chromatic_adaptation(xyz, src, dst, method="Von Kries", transform="Bradford")
    return {}, [out]


def op_xy_to_cct_mccamy(args, arrays):
    import colour

    return {}, [colour.temperature.xy_to_CCT(arrays[0], "McCamy 1992")]


def op_xy_to_cct_robertson(args, arrays):
    """arrays: xy (N,2). Robertson 1968 through CIE 1960 UCS, as colour-hdri's DNG code does."""
    import colour

    uv = colour.UCS_to_uv(colour.XYZ_to_UCS(colour.xy_to_XYZ(arrays[0])))
    return {}, [colour.temperature.uv_to_CCT_Robertson1968(uv)[..., 0]]


def neutral_to_xy_bounded(dng, neutral, common, epsilon=1e-14, passes=5000):
    """colour-hdri's `camera_neutral_to_xy` loop, step for step (its matrix, its stopping rule),
    with a bound on the passes: colour-hdri's own loop has none, and for a neutral far from the
    locus the plain iteration alternates forever. NaN where it did not converge."""
    from colour.models import XYZ_to_xy

    xy = np.array((1 / 3, 1 / 3))
    for _ in range(passes):
        xy_p = np.copy(xy)
        m = dng.matrix_XYZ_to_camera_space(xy, *common)
        xy = XYZ_to_xy(np.linalg.inv(m) @ neutral)
        if np.abs(np.sum(xy_p - xy)) <= epsilon:
            return xy
    return np.array((np.nan, np.nan))


def op_dng_colour(args, arrays):
    """The DNG specification's "Mapping Camera Color Space to CIE XYZ Space", by colour-hdri.
    args: cct1 < cct2 (kelvin). arrays: ColorMatrix1, ColorMatrix2, CameraCalibration1,
    CameraCalibration2 (3,3), AnalogBalance (3,), ForwardMatrix1, ForwardMatrix2 (3,3; identity
    for none, colour-hdri's convention), camera neutrals (N,3), white chromaticities (M,2).
    Returns each neutral's xy (N,2), each white's camera neutral (M,3) and its
    CameraToXYZ_D50 (M,3,3)."""
    from colour_hdri.models import dng

    cm1, cm2, cc1, cc2, ab, fm1, fm2, neutrals, whites = arrays
    t1, t2 = args["cct1"], args["cct2"]
    common = (t1, t2, cm1, cm2, cc1, cc2, ab)
    xys = [neutral_to_xy_bounded(dng, n, common) for n in neutrals]
    back = [dng.xy_to_camera_neutral(xy, *common) for xy in whites]
    to_xyz = [dng.matrix_camera_space_to_XYZ(xy, *common, fm1, fm2) for xy in whites]
    return {}, [np.array(xys), np.array(back), np.array(to_xyz)]


def op_cct_to_xy_daylight(args, arrays):
    import colour

    return {}, [colour.temperature.CCT_to_xy_CIE_D(arrays[0])]


def op_xyz_to_lab(args, arrays):
    """arrays: XYZ (N,3), reference white chromaticity xy (2,)."""
    import colour

    xyz, white_xy = arrays
    return {}, [colour.XYZ_to_Lab(xyz, white_xy)]


def op_delta_e_2000(args, arrays):
    import colour

    return {}, [colour.delta_E(arrays[0], arrays[1], method="CIE 2000")]


def _camera(args):
    return np.eye(3)


def op_project_points(args, arrays):
    """arrays: ideal normalised points (N,2), distortion [k1,k2,p1,p2,k3] (5,)."""
    import cv2

    pts, dist = arrays
    obj = np.concatenate([pts, np.ones((len(pts), 1))], axis=1).reshape(-1, 1, 3)
    out, _ = cv2.projectPoints(obj, np.zeros(3), np.zeros(3), _camera(args), dist)
    return {}, [out.reshape(-1, 2)]


def op_undistort_points(args, arrays):
    """arrays: distorted normalised points (N,2), distortion (5,). Iterated to convergence."""
    import cv2

    pts, dist = arrays
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, int(args.get("iterations", 1000)), 1e-15)
    out = cv2.undistortPoints(pts.reshape(-1, 1, 2), _camera(args), dist, None, None, np.eye(3), criteria)
    return {}, [out.reshape(-1, 2)]


def op_undistort(args, arrays):
    """args: fx, fy, cx, cy (pixels). arrays: image (H,W,3) u8 or u16, distortion [k1,k2,p1,p2,k3].
    cv2.undistort with the camera matrix as the new one: the same frame, corrected."""
    import cv2

    img, dist = arrays
    k = np.array([[args["fx"], 0.0, args["cx"]], [0.0, args["fy"], args["cy"]], [0.0, 0.0, 1.0]])
    return {}, [cv2.undistort(np.ascontiguousarray(img), k, np.ascontiguousarray(dist, dtype=np.float64))]


def op_matrix_colour_correction(args, arrays):
    """arrays: camera values M_T (N,3), reference values M_R (N,3). Cheung 2004, 3 terms."""
    import colour

    m_t, m_r = arrays
    return {}, [colour.characterisation.matrix_colour_correction(m_t, m_r, method="Cheung 2004", terms=3)]


# OpenCV names Bayer codes by the second row of the 2x2 block (DESIGN.md): RGGB is BayerBG.
BAYER_TO_RGB = {
    "RGGB": "COLOR_BayerBG2RGB",
    "BGGR": "COLOR_BayerRG2RGB",
    "GRBG": "COLOR_BayerGB2RGB",
    "GBRG": "COLOR_BayerGR2RGB",
}


def op_bayer_bilinear(args, arrays):
    """args: pattern (camsim's name, top-left block). arrays: mosaic (H,W) u8 or u16."""
    import cv2

    code = getattr(cv2, BAYER_TO_RGB[args["pattern"]])
    return {"code": BAYER_TO_RGB[args["pattern"]]}, [cv2.cvtColor(np.ascontiguousarray(arrays[0]), code)]


def op_bayer_vng(args, arrays):
    """args: pattern. arrays: mosaic (H,W) u8 (OpenCV's VNG is 8-bit only)."""
    import cv2

    code = getattr(cv2, BAYER_TO_RGB[args["pattern"]] + "_VNG")
    return {}, [cv2.cvtColor(np.ascontiguousarray(arrays[0]), code)]


def op_malvar2004(args, arrays):
    """args: pattern. arrays: mosaic (H,W), any dtype. Float RGB, unclipped, as the library gives."""
    from colour_demosaicing import demosaicing_CFA_Bayer_Malvar2004

    cfa = arrays[0].astype(np.float64)
    return {}, [demosaicing_CFA_Bayer_Malvar2004(cfa, args["pattern"])]


def op_rawpy_read(args, arrays):
    """args: path of a DNG. Returns LibRaw's view of it: the raw samples (H,W) u16, raw_pattern
    (2,2) u8 (LibRaw's colour indices: 0 R, 1 G, 2 B, 3 second G), black level per channel (4,),
    white level, color_matrix (LibRaw's camera-to-sRGB matrix derived from the D65 ColorMatrix,
    3x3) and the as-shot white balance (camera_whitebalance, 4 values). LibRaw refuses images
    smaller than 22 x 22."""
    import rawpy

    with rawpy.imread(args["path"]) as raw:
        return {
            "white_level": int(raw.white_level),
            "num_colors": int(raw.num_colors),
            "color_desc": raw.color_desc.decode(),
            "has_pattern": raw.raw_pattern is not None,
        }, [
            np.array(raw.raw_image_visible, dtype=np.uint16),
            # A linear (already demosaiced) DNG has no pattern; its raw is H x W x 4.
            np.array(raw.raw_pattern if raw.raw_pattern is not None else np.zeros((2, 2)), dtype=np.uint8),
            np.array(raw.black_level_per_channel, dtype=np.float64),
            np.array(raw.color_matrix[:, :3], dtype=np.float64),
            np.array(raw.camera_whitebalance, dtype=np.float64),
        ]


def op_rawpy_develop(args, arrays):
    """args: path of a DNG. Returns LibRaw's development (H,W,3) u8: bilinear demosaic, the
    camera's white balance, sRGB primaries and curve, no automatic brightening, and the white
    level as the file states it (adjust_maximum_thr 0: LibRaw otherwise lowers it to the
    frame's largest sample when that is above 75 % of it)."""
    import rawpy

    with rawpy.imread(args["path"]) as raw:
        rgb = raw.postprocess(
            demosaic_algorithm=rawpy.DemosaicAlgorithm.LINEAR,
            use_camera_wb=True,
            no_auto_bright=True,
            output_bps=8,
            gamma=(2.4, 12.92),
            adjust_maximum_thr=0.0,
        )
    return {}, [np.array(rgb, dtype=np.uint8)]


def op_pidng_write(args, arrays):
    """args: path, bits (8, 10, 12, 14 or 16), compress (lossless JPEG, else packed
    uncompressed), pattern (CFA codes, 4 values), black, white. arrays[0]: the samples (H,W)
    u16. Optional args: color_matrix (9 values, ColorMatrix1 under D65; identity if absent),
    neutral (AsShotNeutral, 3 values). Writes a DNG with pidng (an independent writer) as one
    tile covering the image."""
    from pidng.core import RAW2DNG, DNGTags, Tag
    from pidng.defs import DNGVersion, PhotometricInterpretation

    samples = np.ascontiguousarray(arrays[0], dtype=np.uint16)
    height, width = samples.shape
    tags = DNGTags()
    tags.set(Tag.ImageWidth, width)
    tags.set(Tag.ImageLength, height)
    tags.set(Tag.TileWidth, width)
    tags.set(Tag.TileLength, height)
    tags.set(Tag.Orientation, 1)
    tags.set(Tag.PhotometricInterpretation, PhotometricInterpretation.Color_Filter_Array)
    tags.set(Tag.SamplesPerPixel, 1)
    tags.set(Tag.BitsPerSample, int(args["bits"]))
    tags.set(Tag.CFARepeatPatternDim, [2, 2])
    tags.set(Tag.CFAPattern, [int(v) for v in args["pattern"]])
    tags.set(Tag.BlackLevel, int(args["black"]))
    tags.set(Tag.WhiteLevel, int(args["white"]))
    color_matrix = args.get("color_matrix", [1, 0, 0, 0, 1, 0, 0, 0, 1])
    tags.set(Tag.ColorMatrix1, [[round(v * 10000), 10000] for v in color_matrix])
    tags.set(Tag.CalibrationIlluminant1, 21)
    neutral = args.get("neutral", [0.5, 1.0, 2 / 3])
    tags.set(Tag.AsShotNeutral, [[round(v * 1000000), 1000000] for v in neutral])
    tags.set(Tag.DNGVersion, DNGVersion.V1_4)
    tags.set(Tag.Make, "pidng")
    tags.set(Tag.Model, "oracle")
    tags.set(Tag.UniqueCameraModel, "pidng oracle")
    path = pathlib.Path(args["path"])
    writer = RAW2DNG()
    writer.options(tags, path=str(path.parent), compress=bool(args["compress"]))
    writer.convert(samples, filename=path.stem)
    return {}, []


def _wide_quant_tables(jpeg):
    """The same JPEG with its quantisation tables stored with 16-bit entries (Pq = 1), as
    Blackmagic cameras write them (LibRaw's DCT decoder reads only that form)."""
    out = bytearray(jpeg[:2])
    i = 2
    while True:
        if jpeg[i] != 0xFF:
            raise ValueError("expected a marker")
        marker, n = jpeg[i + 1], jpeg[i + 2] << 8 | jpeg[i + 3]
        segment = jpeg[i + 4 : i + 2 + n]
        if marker == 0xDB:
            body, k = bytearray(), 0
            while k < len(segment):
                pq, tq = segment[k] >> 4, segment[k] & 15
                entries = segment[k + 1 : k + 1 + 64 * (pq + 1)]
                if pq == 0:
                    body += bytes([0x10 | tq]) + b"".join(bytes([0, v]) for v in entries)
                else:
                    body += bytes([segment[k]]) + entries
                k += 1 + 64 * (pq + 1)
            out += bytes([0xFF, 0xDB]) + (len(body) + 2).to_bytes(2, "big") + body
        else:
            out += jpeg[i : i + 2 + n]
        if marker == 0xDA:
            return bytes(out + jpeg[i + 2 + n :])
        i += 2 + n


def _tiff_entry(tag, kind, values):
    """One IFD entry's (tag, type, count, bytes), little-endian."""
    import struct

    packers = {1: "B", 2: "s", 3: "H", 4: "I", 5: "II", 10: "ii"}
    if kind == 2:
        data = values
        count = len(values)
    elif kind in (5, 10):
        data = b"".join(struct.pack("<" + packers[kind], *v) for v in values)
        count = len(values)
    else:
        data = b"".join(struct.pack("<" + packers[kind], v) for v in values)
        count = len(values)
    return tag, kind, count, data


def op_dct_dng_write(args, arrays):
    """args: path, tile (width, height; the height even), quality (libjpeg's 1..100), pattern
    (CFA codes, 4 values), black, white. arrays[0]: the samples (H,W) u16, 12-bit. Writes a
    CFA DNG as a Blackmagic camera writes its lossy CinemaDNG: Compression 7, each tile a
    12-bit sequential DCT JPEG (SOF1, one component) two CFA rows per JPEG row, made by
    libjpeg-turbo (imagecodecs) with its quantisation tables stored 16-bit. Edge tiles are
    padded with zeros."""
    import struct
    import imagecodecs

    samples = np.ascontiguousarray(arrays[0], dtype=np.uint16)
    height, width = samples.shape
    tile_w, tile_h = (int(v) for v in args["tile"])
    tiles = []
    for y in range(0, height, tile_h):
        for x in range(0, width, tile_w):
            tile = np.zeros((tile_h, tile_w), np.uint16)
            part = samples[y : y + tile_h, x : x + tile_w]
            tile[: part.shape[0], : part.shape[1]] = part
            jpeg = imagecodecs.jpeg8_encode(
                tile.reshape(tile_h // 2, 2 * tile_w), level=int(args["quality"]), bitspersample=12
            )
            tiles.append(_wide_quant_tables(jpeg))
    colour = [0.9, -0.3, -0.1, -0.4, 1.3, 0.1, -0.1, 0.2, 0.6]
    entries = [
        _tiff_entry(254, 4, [0]),
        _tiff_entry(256, 4, [width]),
        _tiff_entry(257, 4, [height]),
        _tiff_entry(258, 3, [12]),
        _tiff_entry(259, 3, [7]),
        _tiff_entry(262, 3, [32803]),
        _tiff_entry(271, 2, b"oracle\0"),
        _tiff_entry(272, 2, b"dct\0"),
        _tiff_entry(274, 3, [1]),
        _tiff_entry(277, 3, [1]),
        _tiff_entry(284, 3, [1]),
        _tiff_entry(322, 4, [tile_w]),
        _tiff_entry(323, 4, [tile_h]),
        _tiff_entry(324, 4, [0] * len(tiles)),
        _tiff_entry(325, 4, [len(t) for t in tiles]),
        _tiff_entry(33421, 3, [2, 2]),
        _tiff_entry(33422, 1, [int(v) for v in args["pattern"]]),
        _tiff_entry(50706, 1, [1, 4, 0, 0]),
        _tiff_entry(50708, 2, b"oracle dct\0"),
        _tiff_entry(50714, 4, [int(args["black"])]),
        _tiff_entry(50717, 4, [int(args["white"])]),
        _tiff_entry(50721, 10, [(round(v * 10000), 10000) for v in colour]),
        _tiff_entry(50728, 5, [(1, 2), (1, 1), (2, 3)]),
        _tiff_entry(50778, 3, [21]),
    ]
    # Header, IFD, then each value longer than 4 bytes, then the tiles (each word-aligned).
    at = 8 + 2 + 12 * len(entries) + 4
    placed = []
    for tag, kind, count, data in entries:
        if len(data) > 4:
            placed.append(at)
            at += len(data) + len(data) % 2
        else:
            placed.append(None)
    tile_offsets = []
    for t in tiles:
        tile_offsets.append(at)
        at += len(t) + len(t) % 2
    out = bytearray(b"II*\0" + struct.pack("<IH", 8, len(entries)))
    values = bytearray()
    for (tag, kind, count, data), where in zip(entries, placed):
        if tag == 324:
            data = b"".join(struct.pack("<I", v) for v in tile_offsets)
        if where is None:
            out += struct.pack("<HHI", tag, kind, count) + data.ljust(4, b"\0")
        else:
            out += struct.pack("<HHII", tag, kind, count, where)
            values += data + b"\0" * (len(data) % 2)
    out += struct.pack("<I", 0) + values
    for t in tiles:
        out += t + b"\0" * (len(t) % 2)
    pathlib.Path(args["path"]).write_bytes(bytes(out))
    return {"tiles": len(tiles)}, []


def op_image_read(args, arrays):
    """args: path of an image file. Returns what OpenCV reads, unchanged in depth: (H,W,3) in
    RGB order, or (H,W) for grey, as float64."""
    import cv2

    image = cv2.imread(args["path"], cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ValueError(f"OpenCV could not read {args['path']}")
    if image.ndim == 3:
        image = image[:, :, ::-1]
    return {"dtype": str(image.dtype)}, [np.ascontiguousarray(image, dtype=np.float64)]


OPS = {name[3:]: fn for name, fn in globals().items() if name.startswith("op_")}


def main():
    stdin = sys.stdin.buffer
    stdout = sys.stdout.buffer
    # Anything a library prints must not corrupt the reply stream.
    sys.stdout = sys.stderr
    warnings.simplefilter("ignore")
    while True:
        try:
            header, arrays = read_message(stdin)
        except EOFError:
            return
        op = header.get("op")
        try:
            if op not in OPS:
                raise ValueError(f"unknown op {op!r}; known: {sorted(OPS)}")
            values, out = OPS[op](header.get("args", {}), arrays)
            write_message(stdout, {"ok": True, "values": values}, out)
        except Exception as e:  # reported to the Rust side, which fails the test with it
            write_message(stdout, {"ok": False, "error": f"{op}: {e}\n{traceback.format_exc()}"})


if __name__ == "__main__":
    main()

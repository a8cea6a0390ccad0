"""Load MR images from DICOM (file, series folder, enhanced multi-frame), NIfTI, PNG/TIFF and NPY.

Every loader returns an :class:`mri.image.MriImage` with float pixels of shape
``(slices, rows, cols)`` and whatever metadata the format carries. Anything that is not a
usable image raises :class:`mri.errors.ImageLoadError` with the path in the message.
"""

from __future__ import annotations

import math
import struct
from functools import lru_cache
from pathlib import Path

import numpy as np

from mri.errors import ImageLoadError
from mri.image import MriImage, as_pixels

#: DICOM keywords of the protocol fields a pair must share, with the names used in reports.
#: Each entry lists the classic keyword first and the enhanced multi-frame one second.
DICOM_ACQUISITION_FIELDS = {
    "repetition_time_ms": ("RepetitionTime",),
    "echo_time_ms": ("EchoTime", "EffectiveEchoTime"),
    "flip_angle_deg": ("FlipAngle",),
    "pixel_bandwidth_hz": ("PixelBandwidth",),
    "averages": ("NumberOfAverages",),
    "field_strength_t": ("MagneticFieldStrength",),
    "sequence": ("ScanningSequence", "PulseSequenceName"),
    "phase_steps": ("NumberOfPhaseEncodingSteps", "MRAcquisitionPhaseEncodingStepsInPlane"),
    "frequency_steps": ("MRAcquisitionFrequencyEncodingSteps",),
    "acquisition_matrix": ("AcquisitionMatrix",),
}

#: When each image was acquired: the enhanced per-frame time first (an anonymiser may blank
#: the top-level one, as in hazen's Sola files), then the classic date and time.
DICOM_TIME_KEYWORDS = ("FrameAcquisitionDateTime", "AcquisitionDateTime", "AcquisitionDate",
                       "AcquisitionTime", "ContentDate", "ContentTime")

#: Descriptive DICOM fields that may differ between the images of a pair with only a warning.
DICOM_DESCRIPTIVE_FIELDS = {"receive_coil": ("ReceiveCoilName",)}

#: Transfer syntaxes whose pixel data is stored uncompressed (implicit/explicit VR, little/big
#: endian, deflated): their length is checked against the header.
NATIVE_TRANSFER_SYNTAXES = ("1.2.840.10008.1.2", "1.2.840.10008.1.2.1", "1.2.840.10008.1.2.2",
                            "1.2.840.10008.1.2.1.99")

_TIFF_SUFFIXES = (".tif", ".tiff")
_PNG_SUFFIXES = (".png",)


def load_image(path) -> MriImage:
    """Load an image or volume from ``path`` (a file, or a folder holding one DICOM series)."""
    p = Path(path)
    if p.is_dir():
        return load_dicom_series(p)
    if not p.is_file():
        raise ImageLoadError(f"{p}: no such file or folder")
    name = p.name.lower()
    if name.endswith((".nii", ".nii.gz")):
        return load_nifti(p)
    if name.endswith(_PNG_SUFFIXES + _TIFF_SUFFIXES):
        return load_raster(p)
    if name.endswith(".npy"):
        return load_npy(p)
    return load_dicom_file(p)


# --------------------------------------------------------------------------- DICOM


#: Every top-level attribute the DICOM loaders read. pydicom reads only these values (the
#: rest of the header, such as a scanner's private blocks, is skipped: 6 % of the read time
#: of the real Siemens image, and less memory); pixel data that needs pydicom's decoders is
#: read again in full.
DICOM_READ_KEYWORDS = frozenset(
    ("SpecificCharacterSet", "SOPClassUID", "SeriesInstanceUID", "InstanceNumber",
     "SeriesNumber", "SeriesDescription", "Manufacturer", "ManufacturerModelName",
     "PixelSpacing", "SliceThickness", "ImageOrientationPatient", "ImagePositionPatient",
     "RescaleSlope", "RescaleIntercept", "Rows", "Columns", "NumberOfFrames", "SamplesPerPixel",
     "PhotometricInterpretation", "BitsAllocated", "BitsStored", "PixelRepresentation",
     "PixelData", "PerFrameFunctionalGroupsSequence", "SharedFunctionalGroupsSequence")
    + DICOM_TIME_KEYWORDS
    + tuple(k for fields in (DICOM_ACQUISITION_FIELDS, DICOM_DESCRIPTIVE_FIELDS)
            for keywords in fields.values() for k in keywords)
)


def _read_dicom(path: Path):
    """Read a DICOM file's header (the attributes of DICOM_READ_KEYWORDS) and pixel data, or
    return None when the file is not DICOM."""
    import pydicom
    from pydicom.errors import InvalidDicomError

    try:
        # from the file, not from its bytes in memory: that costs a few small reads more,
        # but no file-sized buffer (fresh memory costs a page fault per 4 kB)
        ds = pydicom.dcmread(path, specific_tags=[_tag(k) for k in DICOM_READ_KEYWORDS])
    except InvalidDicomError:
        return None
    except (OSError, ValueError, EOFError) as exc:  # truncated or corrupt file
        raise ImageLoadError(f"{path}: unreadable DICOM file ({exc})") from None
    return _Header(ds)


@lru_cache(maxsize=None)
def _tag(keyword: str):
    """The tag of a keyword of DICOM_READ_KEYWORDS (an error for others: they are not read)."""
    from pydicom.tag import Tag

    if keyword not in DICOM_READ_KEYWORDS:
        raise KeyError(f"{keyword} is not in DICOM_READ_KEYWORDS: the loaders do not read it")
    return Tag(keyword)


#: Tags of the enhanced multi-frame functional-group sequences.
_PER_FRAME_GROUPS, _SHARED_GROUPS = 0x52009230, 0x52009229


class _Header:
    """One DICOM dataset as the loaders read it: pydicom's dataset ``ds``, its top-level
    elements indexed once, and whether it is an enhanced multi-frame file (attributes in
    functional groups)."""

    def __init__(self, ds):
        from pydicom.dataelem import RawDataElement

        self.ds, self._raw_type = ds, RawDataElement
        self._elements = dict(ds.items())
        self.enhanced = _PER_FRAME_GROUPS in self._elements or _SHARED_GROUPS in self._elements

    def get(self, keyword: str):
        """Top-level attribute ``keyword``, None when absent.

        Numbers stored as text (VR DS, IS) come as their text (a string, or a list of
        strings for several values), US numbers as ints and OB/OW data as its bytes, read
        straight from the raw element (pydicom's conversion costs about 8 us an element:
        0.2 ms of a 256 x 256 image's 0.8 ms load). Anything else (other VRs, implicit-VR
        files) is pydicom's value.
        """
        element = self._elements.get(_tag(keyword))
        if element is None:
            return None
        if isinstance(element, self._raw_type) and element.value is not None:
            vr, raw = element.VR, element.value
            if vr in ("DS", "IS"):
                items = raw.decode("latin-1").rstrip(" \x00").split("\\")
                return items[0] if len(items) == 1 else items
            if vr == "US" and len(raw) % 2 == 0:
                values = struct.unpack(f"{'<' if element.is_little_endian else '>'}{len(raw) // 2}H", raw)
                return None if not values else values[0] if len(values) == 1 else list(values)
            if vr in ("OB", "OW"):
                return raw
        return self.ds[element.tag].value


def _lookup(header: _Header, keyword: str, frame: int = 0):
    """A DICOM attribute from frame ``frame``'s functional groups, the shared ones, or the top level.

    Enhanced multi-frame files keep spacing, orientation, rescale and timing inside
    per-frame and shared functional-group sequences; classic files keep them at the top level.
    """
    if not header.enhanced:  # a classic file (fast path)
        return header.get(keyword)
    for group_keyword in ("PerFrameFunctionalGroupsSequence", "SharedFunctionalGroupsSequence"):
        groups = header.ds.get(group_keyword)
        if not groups:
            continue
        if group_keyword == "PerFrameFunctionalGroupsSequence" and frame >= len(groups):
            raise ImageLoadError(f"frame {frame}: the file's per-frame functional groups hold "
                                 f"only {len(groups)} frames")
        item = groups[min(frame, len(groups) - 1)]
        for element in item:
            if element.VR == "SQ" and len(element.value) and keyword in element.value[0]:
                return element.value[0][keyword].value
    return header.get(keyword)


def _first(header: _Header, keywords: tuple[str, ...]):
    for keyword in keywords:
        value = _lookup(header, keyword)
        if value not in (None, ""):
            return value
    return None


def _plain(value):
    """DICOM value -> JSON-friendly Python value (numbers as float, multi-values joined)."""
    from pydicom.multival import MultiValue

    if value is None:
        return None
    if isinstance(value, (list, tuple, MultiValue)):
        return "\\".join(str(v) for v in value)
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value)


def _header_int(header: _Header, keyword: str, path: Path, default=None) -> int:
    """A DICOM integer attribute, an error naming it when absent or not a positive integer."""
    value = header.get(keyword)
    value = default if value is None else value
    try:
        number = float(value)  # an IS may be written "2.0"
        number = int(number) if number.is_integer() else 0
    except (TypeError, ValueError, OverflowError):
        number = 0
    if number < 1 or number > 2**31:
        raise ImageLoadError(f"{path}: {keyword} = {value!r}: must be a positive whole number")
    return number


def _read_all(path: Path):
    """The whole dataset of a DICOM file, for pydicom's pixel decoders."""
    import pydicom

    return pydicom.dcmread(path)


def _check_pixel_length(header: _Header, path: Path) -> tuple[int, int, int, int] | None:
    """Refuse truncated or inconsistent native pixel data: its length must hold rows x
    columns x frames x samples pixels of BitsAllocated bits (compressed data is checked by
    its decoder). Returns (rows, cols, frames, bits) of native data, None otherwise."""
    if _transfer_syntax(header) not in NATIVE_TRANSFER_SYNTAXES:
        return None
    rows, cols = _header_int(header, "Rows", path), _header_int(header, "Columns", path)
    frames = _header_int(header, "NumberOfFrames", path, 1)
    bits = _header_int(header, "BitsAllocated", path)
    if bits not in (1, 8, 16, 32, 64):
        raise ImageLoadError(f"{path}: BitsAllocated = {bits}: must be 1, 8, 16, 32 or 64")
    expected = (rows * cols * frames * bits + 7) // 8
    found = len(header.get("PixelData"))
    if found < expected or found > expected + 1:  # one pad byte makes an odd length even
        raise ImageLoadError(
            f"{path}: pixel data holds {found} bytes, but Rows x Columns x NumberOfFrames x "
            f"BitsAllocated = {rows} x {cols} x {frames} x {bits} bits needs {expected}; the "
            "file is truncated or its header is inconsistent"
        )
    return rows, cols, frames, bits


def _transfer_syntax(header: _Header) -> str:
    return header.ds.file_meta.get("TransferSyntaxUID", "1.2.840.10008.1.2")


def _native_pixels(header: _Header, path: Path):
    """Pixels of little-endian native data read straight from the buffer (what pydicom's
    ``pixel_array`` decodes, without its overhead), after the length check; None for other
    encodings (pydicom decodes them)."""
    layout = _check_pixel_length(header, path)
    if layout is None or _transfer_syntax(header) not in NATIVE_TRANSFER_SYNTAXES[:2]:
        return None
    rows, cols, frames, bits = layout
    if bits not in (8, 16, 32):
        return None
    signed = header.get("PixelRepresentation") == 1
    stored = _header_int(header, "BitsStored", path, bits)
    dtype = np.dtype(f"<{'i' if signed else 'u'}{bits // 8}")
    pixels = np.frombuffer(header.get("PixelData"), dtype=dtype, count=rows * cols * frames)
    pixels = pixels.reshape(frames, rows, cols)
    if stored < bits:  # keep the stored bits only; sign-extend signed values
        lo, hi = (-(1 << (stored - 1)), (1 << (stored - 1)) - 1) if signed else (0, (1 << stored) - 1)
        if pixels.max() > hi or (signed and pixels.min() < lo):  # bits above the stored ones
            shift = bits - stored
            pixels = (pixels << shift) >> shift if signed else pixels & hi
    return pixels if frames > 1 else pixels[0]


def _numbers(header: _Header, keyword: str, count: int, path, frame: int = 0) -> tuple[float, ...] | None:
    """A multi-valued DICOM number (PixelSpacing, ImagePositionPatient, ...) as ``count``
    finite floats, None when absent; an error naming it otherwise."""
    value = _lookup(header, keyword, frame)
    if value in (None, ""):
        return None
    values = [value] if isinstance(value, (str, bytes, int, float)) else list(value)
    try:
        numbers = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        numbers = ()
    if len(numbers) != count or not all(math.isfinite(v) for v in numbers):
        raise ImageLoadError(f"{path}: {keyword} = {value!r}: must be {count} finite number(s)")
    return numbers


def _dicom_frames(header: _Header, path: Path) -> np.ndarray:
    """Pixels of one DICOM dataset as floats (frames, rows, cols) with the rescale applied."""
    ds = header.ds
    if "PixelData" not in ds:
        sop = getattr(ds.get("SOPClassUID"), "name", ds.get("SOPClassUID"))
        raise ImageLoadError(f"{path}: DICOM file without pixel data (SOP class {sop!s})")
    samples = header.get("SamplesPerPixel")
    if samples is not None and int(samples) != 1:
        raise ImageLoadError(
            f"{path}: colour DICOM ({ds.get('PhotometricInterpretation')}); "
            "MR magnitude images must be greyscale"
        )
    raw = _native_pixels(header, path)
    try:
        raw = _read_all(path).pixel_array if raw is None else raw
    except Exception as exc:  # pydicom raises many types for unsupported encodings
        raise ImageLoadError(f"{path}: cannot decode DICOM pixel data ({exc})") from None
    frames = as_pixels(raw, str(path))
    slopes = [(_numbers(header, "RescaleSlope", 1, path, k) or (1.0,))[0] for k in range(frames.shape[0])]
    intercepts = [(_numbers(header, "RescaleIntercept", 1, path, k) or (0.0,))[0]
                  for k in range(frames.shape[0])]
    if any(s == 0.0 for s in slopes):
        raise ImageLoadError(f"{path}: RescaleSlope = 0 would erase the image")
    if any(s != 1.0 for s in slopes) or any(i != 0.0 for i in intercepts):
        frames = frames * np.array(slopes)[:, None, None] + np.array(intercepts)[:, None, None]
        if not np.isfinite(frames).all():
            raise ImageLoadError(f"{path}: RescaleSlope/RescaleIntercept make pixel values "
                                 "overflow; pixels must be finite")
    return frames


def _dicom_image(header: _Header, pixels: np.ndarray, source: str) -> MriImage:
    """Build an :class:`MriImage` from one dataset's metadata (the first slice's) and pixels."""
    path = Path(source)
    spacing = _numbers(header, "PixelSpacing", 2, path)
    if spacing is not None and min(spacing) <= 0:
        raise ImageLoadError(f"{path}: PixelSpacing = {spacing}: must be positive")
    thickness = _numbers(header, "SliceThickness", 1, path)
    orientation = _numbers(header, "ImageOrientationPatient", 6, path)
    position = _numbers(header, "ImagePositionPatient", 3, path)
    scanner = " ".join(
        str(v)
        for v in (header.get("Manufacturer"), header.get("ManufacturerModelName"))
        if v not in (None, "")
    )
    series_number = _numbers(header, "SeriesNumber", 1, path)
    acquisition = {"acquired": _acquired(header)} | {
        name: _plain(_first(header, keywords)) for name, keywords in DICOM_ACQUISITION_FIELDS.items()
    }
    acquisition.update(
        {name: _plain(_first(header, keywords)) for name, keywords in DICOM_DESCRIPTIVE_FIELDS.items()}
    )
    return MriImage(
        pixels=pixels,
        source=source,
        format="dicom",
        pixel_spacing_mm=spacing,
        slice_thickness_mm=thickness[0] if thickness else None,
        orientation=orientation,
        position_mm=position,
        series=str(header.get("SeriesDescription") or "") or None,
        series_number=int(series_number[0]) if series_number else None,
        scanner=scanner or None,
        acquisition={k: v for k, v in acquisition.items() if v is not None},
    )


def _acquired(header: _Header) -> str | None:
    """The acquisition date and time as ISO 8601 text ("2025-11-21T14:24:45.805"), from the
    first of DICOM_TIME_KEYWORDS that holds a real date (anonymisers write 0001-01-01); None
    when no header holds one."""
    def text(keyword):
        value = _lookup(header, keyword)
        return str(value).strip() if value not in (None, "") else ""

    def iso(date, time=""):
        if len(date) < 8 or not date[:8].isdigit() or date[:4] == "0001":
            return None
        out = f"{date[:4]}-{date[4:6]}-{date[6:8]}"
        if len(time) >= 4 and time[:4].isdigit():  # hhmm[ss[.ffffff]], kept to milliseconds
            out += f"T{time[:2]}:{time[2:4]}" + (f":{time[4:10]}" if len(time) > 4 else "")
        return out

    for keyword in ("FrameAcquisitionDateTime", "AcquisitionDateTime"):
        value = text(keyword).split("+")[0]
        if iso(value):
            return iso(value[:8], value[8:])
    for date, time in (("AcquisitionDate", "AcquisitionTime"), ("ContentDate", "ContentTime")):
        if iso(text(date)):
            return iso(text(date), text(time))
    return None


def load_dicom_file(path) -> MriImage:
    """One DICOM file: a single image, a classic multi-frame or an enhanced multi-frame file."""
    p = Path(path)
    header = _read_dicom(p)
    if header is None:
        raise ImageLoadError(
            f"{p}: not a DICOM, NIfTI (.nii, .nii.gz), PNG, TIFF or NPY file"
        )
    return _dicom_image(header, _dicom_frames(header, p), str(p))


def _slice_key(header: _Header, path: Path) -> tuple[float, float]:
    """Sort key of a series file: position along the slice normal, then instance number."""
    orientation = _numbers(header, "ImageOrientationPatient", 6, path)
    position = _numbers(header, "ImagePositionPatient", 3, path)
    along = 0.0
    if orientation and position:
        cosines = np.array(orientation)
        along = float(np.dot(np.cross(cosines[:3], cosines[3:]), position))
    instance = _numbers(header, "InstanceNumber", 1, path)
    return along, instance[0] if instance else 0.0


def load_dicom_series(folder) -> MriImage:
    """All image files of the one DICOM series in ``folder``, stacked in slice order.

    Files that are not DICOM or carry no pixel data (DICOMDIR, reports) are skipped. A folder
    with no image, or with more than one series, is an error.
    """
    root = Path(folder)
    headers = []
    for f in sorted(p for p in root.rglob("*") if p.is_file() and not p.name.startswith(".")):
        header = _read_dicom(f)
        if header is not None and "PixelData" in header.ds:
            headers.append((f, header))
    if not headers:
        raise ImageLoadError(f"{root}: folder holds no DICOM image files")
    series = {str(header.get("SeriesInstanceUID") or "") for _, header in headers}
    if len(series) > 1:
        raise ImageLoadError(
            f"{root}: folder holds {len(series)} DICOM series; give a folder with one series "
            "or a single file"
        )
    headers.sort(key=lambda item: _slice_key(item[1], item[0]))
    stacks = [_dicom_frames(header, f) for f, header in headers]
    shapes = {s.shape[1:] for s in stacks}
    if len(shapes) > 1:
        raise ImageLoadError(
            f"{root}: series images differ in size {sorted(shapes)}; all slices must match"
        )
    return _dicom_image(headers[0][1], np.concatenate(stacks), str(root))


# --------------------------------------------------------------------------- other formats


#: RAS (NIfTI) to LPS (DICOM) patient coordinates.
_RAS_TO_LPS = np.diag([-1.0, -1.0, 1.0])


def display_orientation(affine: np.ndarray, shape: tuple[int, ...]) -> tuple[tuple[bool, ...], np.ndarray]:
    """Which voxel axes (i, j[, k]) to flip so that a NIfTI image is stored as a DICOM viewer
    shows it, and the LPS affine (3 x 4, mm) after the flips.

    In-plane, columns (i) and rows (j) must run toward patient left, posterior or inferior,
    whichever their direction is closest to (DICOM's display: radiological, head up);
    slices (k) must run along the normal cross(i, j), the order of a sorted DICOM series.
    The same voxels stored in any flipped order (e.g. dcm2niix's flipped rows) give the same
    pixels, so no result depends on storage order.
    """
    lps = np.column_stack([_RAS_TO_LPS @ affine[:3, :3], _RAS_TO_LPS @ affine[:3, 3]])
    target = np.array([1.0, 1.0, -1.0])  # +L, +P, -S (toward inferior)
    flips = []
    for axis in range(2):
        direction = lps[:, axis]
        dominant = int(np.argmax(np.abs(direction)))
        flips.append(bool(direction[dominant] * target[dominant] < 0))
    if len(shape) == 3:
        u, v = (lps[:, a] * (-1 if f else 1) for a, f in enumerate(flips))
        flips.append(bool(np.dot(np.cross(u, v), lps[:, 2]) < 0))
    for axis, flip in enumerate(flips):
        if flip:
            lps[:, 3] += lps[:, axis] * (shape[axis] - 1)
            lps[:, axis] *= -1
    return tuple(flips), lps


def load_nifti(path) -> MriImage:
    """A NIfTI-1/2 image or volume (scaled), shown as a DICOM viewer would: axes (i, j, k)
    become (slices=k, rows=j, cols=i), each flipped as :func:`display_orientation` says."""
    import nibabel

    p = Path(path)
    try:
        img = nibabel.load(str(p))
        data = img.get_fdata()
    except Exception as exc:  # nibabel raises several types for corrupt headers
        raise ImageLoadError(f"{p}: unreadable NIfTI file ({exc})") from None
    if data.ndim == 4 and data.shape[3] == 1:
        data = data[..., 0]
    if data.ndim not in (2, 3):
        raise ImageLoadError(
            f"{p}: NIfTI image of shape {data.shape}; expected 2-D or 3-D (extract one volume "
            "of a time series first)"
        )
    if not np.all(np.isfinite(img.affine)) or abs(np.linalg.det(img.affine[:3, :3])) == 0:
        raise ImageLoadError(f"{p}: the NIfTI affine is singular or not finite; the file "
                             "carries no usable orientation")
    zooms = [float(z) for z in img.header.get_zooms()[: data.ndim]]
    flips, lps = display_orientation(img.affine, data.shape)
    data = np.flip(data, [axis for axis, flip in enumerate(flips) if flip])
    pixels = as_pixels(np.transpose(data), str(p))
    row_dir = lps[:, 0] / np.linalg.norm(lps[:, 0])
    col_dir = lps[:, 1] / np.linalg.norm(lps[:, 1])
    return MriImage(
        pixels=pixels,
        source=str(p),
        format="nifti",
        pixel_spacing_mm=(zooms[1], zooms[0]),
        slice_thickness_mm=zooms[2] if data.ndim == 3 else None,
        orientation=tuple(float(v) for v in np.concatenate([row_dir, col_dir])),
        position_mm=tuple(float(v) for v in lps[:, 3]),
    )


def _grey(array: np.ndarray, path: Path) -> np.ndarray:
    """Greyscale pixels of a raster image: a grey or grey+alpha image, or RGB with equal channels."""
    if array.ndim == 3 and array.shape[-1] in (2, 3, 4):
        colour = array[..., :3] if array.shape[-1] >= 3 else array[..., :1]
        if not np.all(colour == colour[..., :1]):
            raise ImageLoadError(
                f"{path}: colour image; MR magnitude images must be greyscale"
            )
        return colour[..., 0]
    return array


def load_raster(path) -> MriImage:
    """A PNG or (multi-page) TIFF image; these formats carry no pixel spacing."""
    p = Path(path)
    try:
        if p.name.lower().endswith(_TIFF_SUFFIXES):
            import tifffile

            array = tifffile.imread(p)
        else:
            import imageio.v3 as iio

            array = iio.imread(p)
    except Exception as exc:  # decoders raise many types for corrupt files
        raise ImageLoadError(f"{p}: unreadable image file ({exc})") from None
    fmt = "tiff" if p.name.lower().endswith(_TIFF_SUFFIXES) else "png"
    return MriImage(pixels=as_pixels(_grey(array, p), str(p)), source=str(p), format=fmt)


def load_npy(path) -> MriImage:
    """A NumPy ``.npy`` array of shape (rows, cols) or (slices, rows, cols)."""
    p = Path(path)
    try:
        array = np.load(p, allow_pickle=False)
    except (ValueError, EOFError) as exc:
        raise ImageLoadError(f"{p}: unreadable .npy file ({exc})") from None
    return MriImage(pixels=as_pixels(array, str(p)), source=str(p), format="npy")

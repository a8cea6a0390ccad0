"""Loading images (DICOM file/series/enhanced multi-frame, NIfTI, PNG, TIFF, NPY) and pair checks.

Fixtures are generated here with pydicom, nibabel, imageio and tifffile, so every expected
pixel value and metadata field is known exactly.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.sequence import Sequence
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

from mri.errors import ImageLoadError, PairMismatchError
from mri.io import load_image
from mri.pair import check_pair

MR_IMAGE = "1.2.840.10008.5.1.4.1.1.4"
ENHANCED_MR_IMAGE = "1.2.840.10008.5.1.4.1.1.4.1"
BASIC_TEXT_SR = "1.2.840.10008.5.1.4.1.1.88.11"

SERIES_UID = generate_uid()


def _file_dataset(sop_class: str) -> Dataset:
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = sop_class
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta = meta
    ds.SOPClassUID = sop_class
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "MR"
    return ds


def _set_pixels(ds: Dataset, pixels: np.ndarray) -> None:
    frames = pixels if pixels.ndim == 3 else pixels[np.newaxis]
    ds.Rows, ds.Columns = frames.shape[1:]
    if pixels.ndim == 3:
        ds.NumberOfFrames = frames.shape[0]
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 0
    ds.PixelData = frames.astype(np.uint16).tobytes()


def write_dicom(path, pixels, z=0.0, **fields):
    """A classic MR image file with a realistic protocol; ``fields`` override any keyword."""
    ds = _file_dataset(MR_IMAGE)
    ds.SeriesInstanceUID = SERIES_UID
    ds.SeriesNumber = 2
    ds.SeriesDescription = "se_repeat"
    ds.Manufacturer, ds.ManufacturerModelName, ds.MagneticFieldStrength = "ACME", "Tesla1", 1.5
    ds.PixelSpacing = [0.5, 0.75]
    ds.SliceThickness = 5
    ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    ds.ImagePositionPatient = [-10, -20, z]
    ds.RepetitionTime, ds.EchoTime, ds.FlipAngle = 1000, 30, 90
    ds.PixelBandwidth, ds.NumberOfAverages, ds.ScanningSequence = 130, 1, "SE"
    ds.InstanceNumber = 1
    for key, value in fields.items():
        setattr(ds, key, value)
    _set_pixels(ds, np.asarray(pixels))
    ds.save_as(path, enforce_file_format=True)
    return path


def pattern(shape=(6, 8), offset=0):
    return (np.arange(np.prod(shape)).reshape(shape) * 3 + 10 + offset).astype(np.uint16)


# --------------------------------------------------------------------------- DICOM


def test_dicom_file_pixels_and_metadata(tmp_path):
    path = write_dicom(tmp_path / "a.dcm", pattern(), RescaleSlope=2, RescaleIntercept=-5)
    img = load_image(path)
    assert img.shape == (1, 6, 8) and img.pixels.dtype == np.float64  # rescaled: float64
    np.testing.assert_array_equal(img.pixels[0], pattern() * 2.0 - 5.0)
    assert img.format == "dicom"
    assert img.pixel_spacing_mm == (0.5, 0.75)
    assert img.slice_thickness_mm == 5.0
    assert img.orientation == (1, 0, 0, 0, 1, 0)
    assert img.series == "se_repeat" and img.series_number == 2
    assert img.scanner == "ACME Tesla1"
    assert img.acquisition == {
        "repetition_time_ms": 1000.0, "echo_time_ms": 30.0, "flip_angle_deg": 90.0,
        "pixel_bandwidth_hz": 130.0, "averages": 1.0, "field_strength_t": 1.5, "sequence": "SE",
    }


def _reencoded(path, syntax):
    """The file at ``path`` rewritten with transfer syntax ``syntax`` (RLE, big or implicit)."""
    import warnings

    import pydicom
    from pydicom.uid import RLELossless

    ds = pydicom.dcmread(path)
    out = path.with_name(f"{path.stem}_{syntax.name.replace(' ', '_')}.dcm")
    if syntax == RLELossless:
        ds.compress(RLELossless)
        ds.save_as(out)
        return out
    big = not syntax.is_little_endian
    ds.PixelData = ds.pixel_array.astype(">u2" if big else "<u2").tobytes()
    ds.file_meta.TransferSyntaxUID = syntax
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pydicom deprecates writing big endian
        pydicom.dcmwrite(out, ds, implicit_vr=syntax.is_implicit_VR, little_endian=not big,
                         force_encoding=True)
    return out


@pytest.mark.parametrize("syntax", ["1.2.840.10008.1.2.5", "1.2.840.10008.1.2.2", "1.2.840.10008.1.2"])
def test_every_dicom_encoding_reads_as_pydicom_does(tmp_path, syntax):
    # RLE-compressed (pydicom's decoder), explicit big endian, implicit VR: pixels and every
    # field equal pydicom's full read (values from the raw text and bytes, skipped tags)
    import pydicom
    from pydicom.uid import UID

    from mri.io import DICOM_ACQUISITION_FIELDS, _plain

    source = write_dicom(tmp_path / "a.dcm", pattern((16, 24)), RescaleSlope=2, RescaleIntercept=-5,
                         AcquisitionMatrix=[0, 16, 24, 0], EchoTime=[30, 60.5])
    path = _reencoded(source, UID(syntax))
    ds = pydicom.dcmread(path)
    assert ds.file_meta.TransferSyntaxUID == syntax
    img, reference = load_image(path), load_image(source)
    np.testing.assert_array_equal(img.pixels[0], ds.pixel_array * 2.0 - 5.0)
    for field in ("pixel_spacing_mm", "slice_thickness_mm", "orientation", "position_mm",
                  "series", "series_number", "scanner", "acquisition"):
        assert getattr(img, field) == getattr(reference, field), field
    expected = {name: _plain(ds.get(keywords[0])) for name, keywords in DICOM_ACQUISITION_FIELDS.items()}
    assert img.acquisition == {k: v for k, v in expected.items() if v is not None}
    assert img.acquisition["echo_time_ms"] == "30.0\\60.5"
    assert img.acquisition["acquisition_matrix"] == "0\\16\\24\\0"


def test_dicom_series_folder_sorted_by_position_skipping_non_images(tmp_path):
    folder = tmp_path / "series"
    folder.mkdir()
    for k, z in enumerate([10.0, 0.0, 5.0]):  # written out of order
        write_dicom(folder / f"im{k}.dcm", pattern(offset=int(z)), z=z, InstanceNumber=k + 1)
    (folder / "notes.txt").write_text("not an image")
    report = _file_dataset(BASIC_TEXT_SR)
    report.SeriesInstanceUID = SERIES_UID
    report.save_as(folder / "report.dcm", enforce_file_format=True)
    img = load_image(folder)
    assert img.shape == (3, 6, 8)
    np.testing.assert_array_equal(img.pixels[:, 0, 0], [10.0, 15.0, 20.0])  # z = 0, 5, 10
    assert img.position_mm == (-10.0, -20.0, 0.0)


def test_enhanced_multiframe_reads_functional_groups(tmp_path):
    frames = np.stack([pattern(), pattern(offset=100)])
    ds = _file_dataset(ENHANCED_MR_IMAGE)
    ds.SeriesInstanceUID = generate_uid()
    ds.Manufacturer = "ACME"
    shared = Dataset()
    measures, orient, timing, echo, rescale = Dataset(), Dataset(), Dataset(), Dataset(), Dataset()
    measures.PixelSpacing, measures.SliceThickness = [0.9, 0.9], 3.0
    orient.ImageOrientationPatient = [0, 1, 0, 0, 0, -1]
    timing.RepetitionTime, timing.FlipAngle = 500, 60
    echo.EffectiveEchoTime = 12
    rescale.RescaleSlope, rescale.RescaleIntercept, rescale.RescaleType = 0.5, 1, "US"
    shared.PixelMeasuresSequence = Sequence([measures])
    shared.PlaneOrientationSequence = Sequence([orient])
    shared.MRTimingAndRelatedParametersSequence = Sequence([timing])
    shared.MREchoSequence = Sequence([echo])
    shared.PixelValueTransformationSequence = Sequence([rescale])
    ds.SharedFunctionalGroupsSequence = Sequence([shared])
    per_frame = []
    for k in range(2):
        item, position = Dataset(), Dataset()
        position.ImagePositionPatient = [0, 0, 3.0 * k]
        item.PlanePositionSequence = Sequence([position])
        per_frame.append(item)
    ds.PerFrameFunctionalGroupsSequence = Sequence(per_frame)
    _set_pixels(ds, frames)
    ds.save_as(tmp_path / "enhanced.dcm", enforce_file_format=True)
    img = load_image(tmp_path / "enhanced.dcm")
    assert img.shape == (2, 6, 8)
    np.testing.assert_array_equal(img.pixels, frames * 0.5 + 1.0)
    assert img.pixel_spacing_mm == (0.9, 0.9) and img.slice_thickness_mm == 3.0
    assert img.orientation == (0, 1, 0, 0, 0, -1)
    assert img.position_mm == (0.0, 0.0, 0.0)
    assert img.acquisition["repetition_time_ms"] == 500.0
    assert img.acquisition["echo_time_ms"] == 12.0
    assert img.acquisition["flip_angle_deg"] == 60.0


def test_non_image_dicom_and_empty_folder_are_clear_errors(tmp_path):
    report = _file_dataset(BASIC_TEXT_SR)
    report.save_as(tmp_path / "report.dcm", enforce_file_format=True)
    with pytest.raises(ImageLoadError, match="without pixel data"):
        load_image(tmp_path / "report.dcm")
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.txt").write_text("nothing here")
    with pytest.raises(ImageLoadError, match="no DICOM image"):
        load_image(empty)
    with pytest.raises(ImageLoadError, match="not a DICOM"):
        load_image(empty / "readme.txt")
    with pytest.raises(ImageLoadError, match="no such file"):
        load_image(tmp_path / "missing.dcm")


def test_folder_with_two_series_is_an_error(tmp_path):
    write_dicom(tmp_path / "a.dcm", pattern())
    write_dicom(tmp_path / "b.dcm", pattern(), SeriesInstanceUID=generate_uid())
    with pytest.raises(ImageLoadError, match="2 DICOM series"):
        load_image(tmp_path)


# --------------------------------------------------------------------------- other formats


def test_nifti_volume_axes_and_spacing(tmp_path):
    import nibabel

    data = np.random.default_rng(0).integers(0, 1000, (8, 6, 3)).astype(np.int16)  # (i, j, k)
    nibabel.save(nibabel.Nifti1Image(data, np.diag([0.8, 1.2, 4.0, 1.0])), tmp_path / "v.nii.gz")
    img = load_image(tmp_path / "v.nii.gz")
    assert img.shape == (3, 6, 8)
    # identity affine (RAS): i runs to the right and j to anterior; shown as DICOM shows it,
    # columns run to the patient's left and rows to posterior, so both are flipped
    np.testing.assert_array_equal(img.pixels[2], data[::-1, ::-1, 2].T)
    assert img.orientation == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)  # LPS, as DICOM
    assert img.position_mm == pytest.approx((-7 * 0.8, -5 * 1.2, 0.0))
    # the header stores float32 zooms: 1.2 comes back as 1.2000000477
    assert img.pixel_spacing_mm == pytest.approx((1.2, 0.8), rel=1e-7)
    assert img.slice_thickness_mm == 4.0
    nibabel.save(nibabel.Nifti1Image(data, np.diag([0.8, 1.0, 4.0, 1.0])), tmp_path / "w.nii")
    with pytest.raises(PairMismatchError, match="pixel spacing"):
        check_pair(img, load_image(tmp_path / "w.nii"))


def test_nifti_result_does_not_depend_on_storage_order(tmp_path):
    """The same axial slab stored as DICOM does (rows to posterior) and as dcm2niix does
    (rows flipped, affine adjusted): identical pixels, geometry and SNR."""
    import nibabel

    from mri.roi import parse_roi
    from mri.snr import measure_arrays
    from tests.mri.phantoms import noisy_pair, phantom

    a, b = noisy_pair(phantom(shading=("linear", 0.4), chord_depth=10), 20.0, seed=2)
    spacing, thickness = 0.9765625, 5.0
    # voxel (i=col, j=row): x = -col (LPS +L is RAS -x), y = -row (+P is RAS -y)
    dicom_like = np.array([[-spacing, 0, 0, 100.0], [0, -spacing, 0, 120.0],
                           [0, 0, thickness, -10.0], [0, 0, 0, 1]])
    flipped = dicom_like.copy()
    flipped[:3, 3] += flipped[:3, 1] * (a.shape[0] - 1)
    flipped[:3, 1] *= -1
    results = []
    for name, affine, rows in (("dicom", dicom_like, slice(None)), ("dcm2niix", flipped, slice(None, None, -1))):
        images = []
        for tag, pixels in (("a", a), ("b", b)):
            path = tmp_path / f"{name}-{tag}.nii.gz"
            nibabel.save(nibabel.Nifti1Image(pixels[rows].T[:, :, None].astype(np.float32), affine), path)
            images.append(load_image(path))
        np.testing.assert_array_equal(images[0].pixels[0], a.astype(np.float32))
        result = measure_arrays(images[0].pixels, images[1].pixels, images[0].pixel_spacing_mm,
                              {"nema": (parse_roi("nema5"),), "thesis": (parse_roi("whole"),)})
        results.append((images[0].orientation, images[0].position_mm,
                        [s.snr for s in result.summaries]))
    assert results[0][0] == pytest.approx(results[1][0]) and results[0][1] == pytest.approx(results[1][1])
    assert results[0][2] == results[1][2]


def test_png_tiff_npy_round_trip(tmp_path):
    import imageio.v3 as iio
    import tifffile

    grey = pattern()
    iio.imwrite(tmp_path / "a.png", grey)
    iio.imwrite(tmp_path / "rgb.png", np.repeat(grey.astype(np.uint8)[..., None], 3, axis=2))
    tifffile.imwrite(tmp_path / "v.tif", np.stack([grey, grey + 1]))
    np.save(tmp_path / "a.npy", grey.astype(np.float32))
    np.save(tmp_path / "i32.npy", grey.astype(np.int32))
    np.testing.assert_array_equal(load_image(tmp_path / "a.png").pixels[0], grey)
    np.testing.assert_array_equal(load_image(tmp_path / "rgb.png").pixels[0], grey.astype(np.uint8))
    assert load_image(tmp_path / "v.tif").shape == (2, 6, 8)
    npy = load_image(tmp_path / "a.npy")
    assert npy.format == "npy" and npy.pixel_spacing_mm is None
    # float32 where exact (16-bit integers, float32), float64 for wider integers
    assert (npy.pixels.dtype, load_image(tmp_path / "a.png").pixels.dtype) == (np.float32,) * 2
    assert load_image(tmp_path / "i32.npy").pixels.dtype == np.float64
    np.testing.assert_array_equal(npy.pixels[0], grey)


def test_bad_pixels_are_rejected(tmp_path):
    import imageio.v3 as iio

    nan = pattern().astype(float)
    nan[2, 3] = np.nan
    np.save(tmp_path / "nan.npy", nan)
    with pytest.raises(ImageLoadError, match="1 pixel.*NaN"):
        load_image(tmp_path / "nan.npy")
    np.save(tmp_path / "c.npy", pattern() * (1 + 1j))
    with pytest.raises(ImageLoadError, match="complex"):
        load_image(tmp_path / "c.npy")
    np.save(tmp_path / "4d.npy", np.zeros((2, 2, 2, 2)))
    with pytest.raises(ImageLoadError, match="4 dimensions"):
        load_image(tmp_path / "4d.npy")
    colour = np.zeros((6, 8, 3), dtype=np.uint8)
    colour[..., 0] = 200
    iio.imwrite(tmp_path / "colour.png", colour)
    with pytest.raises(ImageLoadError, match="colour"):
        load_image(tmp_path / "colour.png")


# --------------------------------------------------------------------------- pair checks


def test_matching_dicom_pair_passes_and_descriptive_fields_only_warn(tmp_path):
    a = load_image(write_dicom(tmp_path / "a.dcm", pattern()))
    b = load_image(write_dicom(tmp_path / "b.dcm", pattern(offset=1), SeriesNumber=3,
                               SeriesInstanceUID=generate_uid()))
    assert check_pair(a, b) == ()
    c = load_image(write_dicom(tmp_path / "c.dcm", pattern(), SeriesDescription="other"))
    (warning,) = check_pair(a, c)
    assert warning.startswith("series differs")


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("PixelSpacing", [0.5, 0.8], "pixel spacing"),
        ("SliceThickness", 3, "slice thickness"),
        ("ImageOrientationPatient", [0, 1, 0, 0, 0, -1], "orientation"),
        ("ImagePositionPatient", [-10, -20, 5], "position"),
        ("RepetitionTime", 2000, "repetition_time_ms"),
        ("EchoTime", 15, "echo_time_ms"),
        ("FlipAngle", 30, "flip_angle_deg"),
    ],
)
def test_dicom_pair_mismatch_names_the_field(tmp_path, field, value, message):
    a = load_image(write_dicom(tmp_path / "a.dcm", pattern()))
    b = load_image(write_dicom(tmp_path / "b.dcm", pattern(), **{field: value}))
    with pytest.raises(PairMismatchError, match=message):
        check_pair(a, b)


def test_shape_mismatch_and_spacing_known_for_one_image(tmp_path):
    np.save(tmp_path / "small.npy", pattern((6, 7)))
    np.save(tmp_path / "a.npy", pattern())
    a = load_image(write_dicom(tmp_path / "a.dcm", pattern()))
    with pytest.raises(PairMismatchError, match="shapes differ"):
        check_pair(load_image(tmp_path / "a.npy"), load_image(tmp_path / "small.npy"))
    warnings = check_pair(a, load_image(tmp_path / "a.npy"))
    assert any(w.startswith("pixel spacing (mm) known only for a") for w in warnings)


# --------------------------------------------------------------------------- bad input (issue 14)


def test_truncated_dicom_is_refused(tmp_path):
    path = write_dicom(tmp_path / "a.dcm", pattern((64, 64)))
    data = path.read_bytes()
    path.write_bytes(data[:-100])  # the file lost its last 100 bytes (50 pixels)
    with pytest.raises(ImageLoadError, match=r"pixel data holds 8092 bytes, but Rows x Columns x "
                       r"NumberOfFrames x BitsAllocated = 64 x 64 x 1 x 16 bits needs 8192"):
        load_image(path)


def test_header_inconsistent_with_the_pixel_data_is_refused(tmp_path):
    path = write_dicom(tmp_path / "a.dcm", pattern((64, 64)))
    import pydicom

    ds = pydicom.dcmread(path)
    ds.Rows = 65
    ds.save_as(path)
    with pytest.raises(ImageLoadError, match="65 x 64 x 1 x 16 bits needs 8320"):
        load_image(path)


@pytest.mark.parametrize("field, value, message", [
    ("PixelSpacing", ["abc", "0.5"], "PixelSpacing = .*: must be 2 finite number"),
    ("PixelSpacing", [0.0, 0.5], "PixelSpacing = .*: must be positive"),
    ("ImagePositionPatient", ["1", "x", "3"], "ImagePositionPatient = .*: must be 3 finite number"),
    ("ImageOrientationPatient", [1, 0, 0, 0, 1], "ImageOrientationPatient = .*: must be 6 finite"),
])
def test_non_numeric_geometry_is_one_clear_error(tmp_path, field, value, message):
    import pydicom
    from pydicom.dataelem import DataElement

    path = write_dicom(tmp_path / "a.dcm", pattern())
    ds = pydicom.dcmread(path)
    tag = ds.data_element(field).tag
    ds[tag] = DataElement(tag, "LO", "\\".join(str(v) for v in value))  # bypass DS validation
    ds.save_as(path)
    with pytest.raises(ImageLoadError, match=message):
        load_image(path)


def test_huge_pixel_values_end_in_an_error_naming_the_stage(tmp_path):
    from mri.errors import MeasurementError
    from mri.roi import parse_roi
    from mri.snr import measure_arrays

    rng = np.random.default_rng(0)
    a = 1e305 * (1 + 0.1 * rng.random((1, 32, 32)))
    b = 1e305 * (1 + 0.1 * rng.random((1, 32, 32)))
    for method, roi in (("nema", "central-box:10"), ("thesis", "whole")):
        with pytest.raises(MeasurementError, match="overflow float64") as info:
            measure_arrays(a, b, None, {method: (parse_roi(roi),)})
        assert "noise of ROI" in str(info.value) or "sum" in str(info.value)


@pytest.mark.parametrize("signed, stored", [(0, 16), (0, 12), (1, 16), (1, 12)])
def test_native_pixel_reader_equals_pydicom(tmp_path, signed, stored):
    """The fast reader of native little-endian pixels gives pydicom's pixel_array exactly."""
    import pydicom

    from mri.io import _Header, _native_pixels

    rng = np.random.default_rng(stored + signed)
    lo, hi = (-(2 ** (stored - 1)), 2 ** (stored - 1)) if signed else (0, 2**stored)
    values = rng.integers(lo, hi, (2, 16, 24))
    path = write_dicom(tmp_path / "a.dcm", np.zeros((2, 16, 24)))
    ds = pydicom.dcmread(path)
    ds.PixelRepresentation, ds.BitsStored, ds.HighBit = signed, stored, stored - 1
    ds.PixelData = values.astype(np.int16 if signed else np.uint16).tobytes()
    ds.save_as(path)
    ds = pydicom.dcmread(path)
    np.testing.assert_array_equal(_native_pixels(_Header(ds), path), ds.pixel_array)
    np.testing.assert_array_equal(_native_pixels(_Header(ds), path), values)
    if stored < 16:  # bits above the stored ones (an overlay, or unextended signs) are dropped
        raw = values.astype(np.int16 if signed else np.uint16).view(np.uint16)
        noise = rng.integers(0, 2 ** (16 - stored), values.shape).astype(np.uint16) << stored
        ds.PixelData = ((raw & np.uint16(2**stored - 1)) | noise).tobytes()
        ds.save_as(path)
        ds = pydicom.dcmread(path)
        np.testing.assert_array_equal(_native_pixels(_Header(ds), path), values)
        np.testing.assert_array_equal(_native_pixels(_Header(ds), path), ds.pixel_array)

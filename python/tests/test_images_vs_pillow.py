"""Photos decode as Pillow's Image.open(f).convert("RGB") gives them — the input the networks' reference
preprocessing sees — for every mode Pillow opens: PNG (RGB, RGBA, L, LA, 1-bit, palette with and without
transparency, 16-bit grey), BMP, TIFF, lossless WebP and JPEG (RGB, grey, progressive). Images are made by Pillow
itself from seeded random pixels. CMYK JPEGs differ by at most one level (OpenCV's and Pillow's CMYK→RGB round
differently); phones do not write them."""
import os

import numpy as np
import pytest

import freeloc

PIL = pytest.importorskip("PIL.Image", reason="Pillow (python3-pil) is not installed")


def _cases(rng, h=19, w=23):
    from PIL import Image
    rgb = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    a = rng.integers(0, 256, (h, w), dtype=np.uint8)
    return [
        ("rgb.png", Image.fromarray(rgb), {}),
        ("rgba.png", Image.fromarray(np.dstack([rgb, a]), "RGBA"), {}),
        ("l.png", Image.fromarray(rgb[..., 0]), {}),
        ("la.png", Image.fromarray(np.dstack([rgb[..., 0], a]), "LA"), {}),
        ("bits.png", Image.fromarray(rgb[..., 0] > 128), {}),
        ("p.png", Image.fromarray(rgb).quantize(16), {}),
        ("ptrns.png", Image.fromarray(rgb).quantize(16), {"transparency": 3}),
        ("i16.png", Image.fromarray(rng.integers(0, 65536, (h, w)).astype(np.uint16)), {}),
        ("i16low.png", Image.fromarray(rng.integers(0, 400, (h, w)).astype(np.uint16)), {}),
        ("rgb.bmp", Image.fromarray(rgb), {}),
        ("rgb.tif", Image.fromarray(rgb), {}),
        ("l.tif", Image.fromarray(rgb[..., 0]), {}),
        ("rgb.webp", Image.fromarray(rgb), {"lossless": True}),
        ("rgb.jpg", Image.fromarray(rgb), {"quality": 90}),
        ("l.jpg", Image.fromarray(rgb[..., 0]), {}),
        ("progressive.jpg", Image.fromarray(rgb), {"progressive": True}),
        ("cmyk.jpg", Image.fromarray(rgb).convert("CMYK"), {}),
    ]


@pytest.mark.parametrize("seed", [11, 12])
def test_every_mode_decodes_as_pillow_converts_it(tmp_path, seed):
    from PIL import Image
    for name, im, kw in _cases(np.random.default_rng(seed)):
        path = os.path.join(tmp_path, name)
        im.save(path, **kw)
        want = np.asarray(Image.open(path).convert("RGB"))
        got = freeloc.read_image(path)
        assert got.shape == want.shape, name
        diff = int(np.abs(got.astype(int) - want.astype(int)).max())
        assert diff <= (1 if name == "cmyk.jpg" else 0), f"{name} ({Image.open(path).mode}): max difference {diff}"

"""tools/noise_map.py's comparison figure: the picture and two noise maps
side by side, both maps on the first's scale."""
import numpy as np

import noise_map


def test_both_maps_on_the_first_maps_scale():
    h, w = 4, 50
    picture = np.full((h, w, 3), 77, np.uint8)
    first = np.tile(np.linspace(0.0, 1.0, w), (h, 1))
    scale = np.percentile(first, 99.5)
    second = first * 4.0
    figure = noise_map.side_by_side(picture, first, second, zoom=2)
    assert figure.shape == (2 * h, 3 * 2 * w, 3)
    left, middle, right = (figure[::2, k * 2 * w:(k + 1) * 2 * w:2] for k in range(3))
    assert (left == 77).all()
    # Grey, square-root scaled: a quarter of the scale shows at half.
    quarter = np.argmin(abs(first[0] - scale / 4))
    assert abs(int(middle[0, quarter, 0]) - round(255 * np.sqrt(first[0, quarter] / scale))) <= 1
    assert (middle[..., 0] == middle[..., 1]).all() and (middle[..., 1] == middle[..., 2]).all()
    assert middle[0, -1, 0] == 255
    # The second map, four times the first, is white from a quarter of the
    # first's scale on: it is not scaled to its own.
    assert (right[0, first[0] >= scale / 4, 0] == 255).all()
    assert abs(int(right[0, quarter // 2, 0]) - round(255 * np.sqrt(second[0, quarter // 2] / scale))) <= 1
    # Each pixel shown as a zoom × zoom block.
    assert (figure[0::2] == figure[1::2]).all()
    assert (figure[:, 0::2] == figure[:, 1::2]).all()


def test_a_map_without_noise_is_black():
    assert (noise_map.shown(np.zeros((3, 5)), 0.0) == 0).all()

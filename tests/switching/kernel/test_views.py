"""switching.kernel.views: the workspaces' two-dimensional views, made without numba's reshape."""

import numpy as np
import pytest

numba = pytest.importorskip("numba")
rows_of = pytest.importorskip("switching.kernel.views").rows_of


@numba.njit
def _carved(buffer, offset, rows, columns):
    view = rows_of(buffer[offset:offset + rows * columns], rows, columns)
    view[rows - 1, columns - 1] = view[0, 0]  # written through to the buffer
    return view


@pytest.mark.parametrize("dtype", [np.float64, np.int64, np.bool_])
def test_a_view_is_the_buffers_entries_row_by_row(dtype):
    buffer = np.arange(40).astype(dtype) if dtype is not np.bool_ else np.arange(40) % 3 == 0
    expected = buffer[5:5 + 4 * 6].reshape((4, 6)).copy()
    expected[3, 5] = expected[0, 0]
    view = _carved(buffer, 5, 4, 6)
    assert view.shape == (4, 6) and view.dtype == buffer.dtype and view.flags.c_contiguous
    np.testing.assert_array_equal(view, expected)
    assert buffer[5 + 23] == expected[0, 0]  # the buffer's own entry, not a copy's
    assert view.base is not None  # a view keeps its buffer alive


def test_only_a_contiguous_vector_has_such_views():
    from numba.core.errors import TypingError

    with pytest.raises(TypingError):
        _carved(np.zeros((4, 6)), 0, 2, 3)

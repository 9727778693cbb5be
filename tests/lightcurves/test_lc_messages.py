"""Every refusal of :mod:`lightcurves.io` has the project's one form ``<field>: <value>: expected <form>`` (issue 29).

One bad file per refusal the readers make; the message must name the file and the column, row or byte, then the
value, then what was expected — never ``...; expected ...`` (the form they had before).
"""

import re

import numpy as np
import pytest

from lightcurves.io import BadSeries, read_lightcurve

#: ``<where>: <what is wrong>: expected <form>``, one line.
FORM = r"^\S[^\n]*: \S[^\n]*: expected \S[^\n]*$"
ROWS = "".join(f"{k},{10 + np.sin(k):.3f}\n" for k in range(30))

BAD = {
    "empty cell": ("lc.csv", "time,mag\n" + ROWS + "30,\n", "column 'mag' row 31: empty"),
    "hex cell": ("lc.csv", "time,mag\n" + ROWS + "30,0x10\n", "row 31: '0x10'"),
    "beyond a float": ("lc.csv", "time,mag\n" + ROWS + "30,1e999\n", "row 31: '1e999' (beyond a finite float)"),
    "NUL byte": ("lc.csv", "time,mag\n1,\x002\n", "NUL byte at offset 11"),
    "not UTF-8": ("lc.csv", b"time,mag\n1,\xff\n", "byte 11: not UTF-8"),
    "malformed": ("lc.csv", "time,mag\n1,2\n3,4,5,6\n7\n", "malformed CSV"),
    "repeated column": ("lc.csv", "time,mag,MAG\n1,2,3\n", "a column repeats"),
    "missing column": ("lc.csv", "t,brightness\n1,2\n", "column(s) 'time', 'mag': missing"),
    "empty time": ("lc.csv", "time,mag\n" + ROWS + ",10\n", "column 'time' row 31: empty"),
    "not increasing": ("lc.csv", "time,mag\n" + ROWS + "3,10\n", "time of row 31: before row 30's, not increasing"),
    "MJD": ("lc.csv", "time,mag\n" + "".join(f"{60390.84 + k / 86400:.8f},{10 + np.sin(k):.3f}\n" for k in range(30)), "looks like MJD (days)"),
    "flux <= 0": ("lc.csv", "time,flux\n" + "".join(f"{k},{1.0 if k != 7 else -1.0}\n" for k in range(30)), "column 'flux' row 8: -1"),
    "bad time text": ("lc.csv", "time,mag\n2024-03-21T20:00:00,10\n2024-13-45T99:00:00,11\n", "column 'time' row 2: '2024-13-45T99:00:00'"),
    "not a table file": ("lc.txt", "time,mag\n1,2\n", "lc.txt: not a light-curve file"),
    "unreadable FITS": ("lc.fits", "not FITS", "lc.fits: not a readable"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_each_refusal_names_where_what_and_the_expected_form(tmp_path, case):
    name, content, says = BAD[case]
    path = tmp_path / name
    (path.write_bytes if isinstance(content, bytes) else path.write_text)(content)
    with pytest.raises(BadSeries) as info:
        read_lightcurve(path)
    message = str(info.value)
    assert says in message, message
    assert "; expected" not in message
    assert re.match(FORM, message), message

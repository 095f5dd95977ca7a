"""Tests of spectral_materials.core.colour.spectrum_library (typed text, CSV files, blackbodies).

Reference values: Planck's law written out here with both the CIE's c₂ = 1.4388e-2 m·K
and the CODATA 2018 constants, Wien's displacement law, and colour-science's own
``sd_blackbody``. Every malformed input must raise ValueError, never anything else.
"""

from __future__ import annotations

import builtins
import os
import time

import colour
import numpy as np
import pytest

from spectral_materials.core.colour import spectra
from spectral_materials.core.colour.spectrum_library import (
    MAX_CSV_BYTES,
    MAX_CSV_ROWS,
    SpectrumFileError,
    blackbody_spd,
    check_reflectance,
    check_spd,
    parse_spectrum_text,
    read_spectrum_csv,
    spectrum_to_grid,
)

WL = spectra.WAVELENGTHS_REFERENCE

# CODATA 2018 (exact SI values).
H_PLANCK = 6.62607015e-34
C_LIGHT = 299792458.0
K_BOLTZMANN = 1.380649e-23


def planck_by_hand(wavelength_nm, temperature, c2=None):
    """Spectral radiance up to a constant factor: λ⁻⁵ / (exp(c₂ / λT) − 1)."""
    lam = np.asarray(wavelength_nm, dtype=np.float64) * 1e-9
    if c2 is None:
        c2 = H_PLANCK * C_LIGHT / K_BOLTZMANN
    return 2 * H_PLANCK * C_LIGHT**2 / lam**5 / np.expm1(c2 / (lam * temperature))


def write(tmp_path, text, name="spectrum.csv", encoding="utf-8"):
    path = tmp_path / name
    path.write_bytes(text.encode(encoding) if isinstance(text, str) else text)
    return path


def assert_valid_spectrum(wl, values):
    assert wl.dtype == np.float64 and values.dtype == np.float64
    assert wl.ndim == 1 and wl.shape == values.shape and wl.size >= 1
    assert np.isfinite(wl).all() and np.isfinite(values).all()
    assert np.all(np.diff(wl) > 0)


class TestParseSpectrumText:
    def test_pairs(self):
        wl, values = parse_spectrum_text("400:0.1, 550:0.8, 700:0.3")
        np.testing.assert_array_equal(wl, [400.0, 550.0, 700.0])
        np.testing.assert_array_equal(values, [0.1, 0.8, 0.3])

    def test_pairs_with_spaces_and_mixed_separators(self):
        wl, values = parse_spectrum_text("  400 : 0.1;550:  8e-1\n700:3E-1\t 750 :+.25 ")
        np.testing.assert_array_equal(wl, [400.0, 550.0, 700.0, 750.0])
        np.testing.assert_array_equal(values, [0.1, 0.8, 0.3, 0.25])

    def test_single_pair(self):
        wl, values = parse_spectrum_text("555:0.4")
        np.testing.assert_array_equal(wl, [555.0])
        np.testing.assert_array_equal(values, [0.4])

    def test_plain_values_spread_evenly(self):
        wl, values = parse_spectrum_text("0.1, 0.2; 0.3 0.4\n0.5")
        np.testing.assert_array_equal(wl, [380.0, 480.0, 580.0, 680.0, 780.0])
        np.testing.assert_array_equal(values, [0.1, 0.2, 0.3, 0.4, 0.5])

    def test_two_values_make_a_ramp(self):
        wl, values = parse_spectrum_text("0.2 0.6")
        np.testing.assert_array_equal(wl, [380.0, 780.0])
        np.testing.assert_array_equal(values, [0.2, 0.6])
        grid = spectrum_to_grid(wl, values, WL)
        np.testing.assert_allclose(grid, 0.2 + 0.4 * (WL - 380.0) / 400.0, rtol=0, atol=1e-15)

    def test_one_value_is_a_constant(self):
        wl, values = parse_spectrum_text(" 0.35 ")
        np.testing.assert_array_equal(wl, [380.0, 780.0])
        np.testing.assert_array_equal(values, [0.35, 0.35])
        np.testing.assert_array_equal(spectrum_to_grid(wl, values, WL), np.full(WL.shape, 0.35))

    def test_negative_and_large_values_are_not_range_checked(self):
        _, values = parse_spectrum_text("-1, 2, 1e3")
        np.testing.assert_array_equal(values, [-1.0, 2.0, 1000.0])

    def test_wavelength_limits_inclusive(self):
        wl, _ = parse_spectrum_text("300:1, 900:2")
        np.testing.assert_array_equal(wl, [300.0, 900.0])

    def test_round_trip_pairs(self):
        rng = np.random.default_rng(7)
        wl = np.sort(rng.choice(np.arange(300.0, 900.5, 0.5), size=40, replace=False))
        values = rng.normal(size=40)
        text = ", ".join(f"{w!r}:{v!r}" for w, v in zip(wl.tolist(), values.tolist()))
        got_wl, got_values = parse_spectrum_text(text)
        np.testing.assert_array_equal(got_wl, wl)
        np.testing.assert_array_equal(got_values, values)

    def test_round_trip_plain_colorchecker(self):
        reflectance = spectra.colorchecker(13, WL)  # blue patch, 81 samples on 380..780
        wl, values = parse_spectrum_text(" ".join(repr(v) for v in reflectance.tolist()))
        np.testing.assert_array_equal(wl, WL)
        np.testing.assert_array_equal(values, reflectance)
        np.testing.assert_array_equal(spectrum_to_grid(wl, values, WL), reflectance)

    @pytest.mark.parametrize("text", ["", "   ", "\n\t", ",,;; ,"])
    def test_empty(self, text):
        with pytest.raises(ValueError, match="empty"):
            parse_spectrum_text(text)

    def test_not_a_string(self):
        with pytest.raises(ValueError, match="string"):
            parse_spectrum_text(None)  # type: ignore[arg-type]

    def test_non_number_names_token_and_position(self):
        with pytest.raises(ValueError, match=r"token 3 'abc' at character 11: .*not a number"):
            parse_spectrum_text("0.1, 0.2, abc, 0.4")

    @pytest.mark.parametrize("token", ["1_000", "١٢", "0x10", "1,5e", "--1", "½"])
    def test_non_ascii_or_python_only_numbers(self, token):
        with pytest.raises(ValueError, match="not a number"):
            parse_spectrum_text(f"0.5 {token}")

    @pytest.mark.parametrize("token", ["nan", "NaN", "inf", "-Infinity", "1e999"])
    def test_non_finite_value(self, token):
        with pytest.raises(ValueError, match=rf"token 2 '{token}' at character 6: .*not finite"):
            parse_spectrum_text(f"0.5, {token}")

    def test_non_finite_in_pair(self):
        with pytest.raises(ValueError, match="token 2 .* value: 'nan' is not finite"):
            parse_spectrum_text("400:0.5, 500:nan")
        with pytest.raises(ValueError, match="token 1 .* wavelength: 'inf' is not finite"):
            parse_spectrum_text("inf:0.5")

    def test_not_increasing(self):
        with pytest.raises(ValueError, match=r"token 3 '500:0.3' .* does not increase from 600"):
            parse_spectrum_text("400:0.1, 600:0.2, 500:0.3")

    def test_duplicate_wavelength(self):
        with pytest.raises(ValueError, match="does not increase"):
            parse_spectrum_text("400:0.1, 400:0.2")

    @pytest.mark.parametrize("wl", ["299.9", "900.5", "-400", "0"])
    def test_wavelength_out_of_range(self, wl):
        with pytest.raises(ValueError, match=r"outside 300–900 nm"):
            parse_spectrum_text(f"400:0.1, {wl}:0.2")

    def test_mixing_pairs_then_values(self):
        with pytest.raises(ValueError, match=r"token 2 '0.2' .* starts with wavelength:value"):
            parse_spectrum_text("400:0.1, 0.2")

    def test_mixing_values_then_pairs(self):
        with pytest.raises(ValueError, match=r"token 3 '500:0.2' .* starts with plain values"):
            parse_spectrum_text("0.1 0.3 500:0.2")

    @pytest.mark.parametrize("text", ["400:", ":0.5", "400: , 500:0.2", ":", "400:0.5:3"])
    def test_incomplete_pair(self, text):
        with pytest.raises(ValueError, match="needs both a wavelength and a value"):
            parse_spectrum_text(text)

    def test_too_long(self):
        with pytest.raises(ValueError, match="too long"):
            parse_spectrum_text("0.5 " * 300_000)

    def test_fuzz_random_bytes(self):
        """Random bytes, decoded two ways, are never a spectrum and raise only ValueError."""
        rng = np.random.default_rng(20240501)
        for _ in range(400):
            raw = rng.integers(0, 256, size=int(rng.integers(8, 200)), dtype=np.uint8).tobytes()
            for text in (raw.decode("latin-1"), raw.decode("utf-8", errors="replace")):
                with pytest.raises(ValueError):
                    parse_spectrum_text(text)

    def test_fuzz_number_like_junk(self):
        """Junk made of number characters: either a valid spectrum or a ValueError."""
        rng = np.random.default_rng(11)
        alphabet = list("0123456789....,,;;::  \t\n-+eEnaif")
        ok = 0
        for _ in range(2000):
            text = "".join(rng.choice(alphabet, size=int(rng.integers(0, 40))))
            try:
                wl, values = parse_spectrum_text(text)
            except ValueError:
                continue
            ok += 1
            assert_valid_spectrum(wl, values)
            assert wl[0] >= 300 and wl[-1] <= 900
        assert ok > 0  # the generator does reach the success path


    @pytest.mark.parametrize("text, match", [
        ("0.5 1e308 0.2", r"token 2 '1e308' at character 5: '1e308' is beyond ±1e\+30"),
        ("400:0.5, 500:-2e30", r"token 2 .*, value: '-2e30' is beyond"),
        ("1.0000001e30", "beyond"),
    ])
    def test_extreme_values_refused(self, text, match):
        with pytest.raises(ValueError, match=match):
            parse_spectrum_text(text)

    def test_values_up_to_the_limit(self):
        np.testing.assert_array_equal(parse_spectrum_text("1e30 -1e30")[1], [1e30, -1e30])

    def test_long_digit_run_is_fast_and_quoted_short(self):
        """A number pattern that could split a run of digits two ways backtracked
        quadratically on one that is not a number (minutes for 100,000 digits)."""
        token = "9" * 200_000 + "x"
        start = time.perf_counter()
        with pytest.raises(ValueError, match=r"is not a number") as info:
            parse_spectrum_text("0.5 " + token)
        assert time.perf_counter() - start < 1.0
        assert len(str(info.value)) < 300 and "200,001 characters" in str(info.value)


class TestReadSpectrumCsv:
    def test_comma_with_header_and_comments(self, tmp_path):
        path = write(tmp_path, "# measured 2024\nwavelength_nm,reflectance\n"
                               "400,0.10\n450, 0.20 # a note\n\n500,0.30\n")
        wl, values = read_spectrum_csv(path)
        np.testing.assert_array_equal(wl, [400.0, 450.0, 500.0])
        np.testing.assert_array_equal(values, [0.1, 0.2, 0.3])

    def test_str_path_semicolon_decimal_comma(self, tmp_path):
        path = write(tmp_path, "Wellenlänge;Wert\r\n400;0,10\r\n450;0,25\r\n",
                     encoding="latin-1")
        wl, values = read_spectrum_csv(str(path))
        np.testing.assert_array_equal(wl, [400.0, 450.0])
        np.testing.assert_array_equal(values, [0.10, 0.25])

    def test_tab_and_blanks(self, tmp_path):
        wl, values = read_spectrum_csv(write(tmp_path, "nm\tvalue\n400\t1\n500\t2\n"))
        np.testing.assert_array_equal(values, [1.0, 2.0])
        wl, values = read_spectrum_csv(write(tmp_path, "400  1\n500 2.5\n", "b.txt"))
        np.testing.assert_array_equal(wl, [400.0, 500.0])
        np.testing.assert_array_equal(values, [1.0, 2.5])

    def test_bom_utf16_and_trailing_separator(self, tmp_path):
        text = "wl,value,\n400,0.5,\n410,0.6,\n"
        for encoding in ("utf-8-sig", "utf-16"):
            wl, values = read_spectrum_csv(write(tmp_path, text, f"{encoding}.csv", encoding))
            np.testing.assert_array_equal(wl, [400.0, 410.0])
            np.testing.assert_array_equal(values, [0.5, 0.6])

    def test_decreasing_file_is_reversed(self, tmp_path):
        wl, values = read_spectrum_csv(write(tmp_path, "700,3\n600,2\n500,1\n"))
        np.testing.assert_array_equal(wl, [500.0, 600.0, 700.0])
        np.testing.assert_array_equal(values, [1.0, 2.0, 3.0])

    def test_negative_values_allowed(self, tmp_path):
        _, values = read_spectrum_csv(write(tmp_path, "400,-0.01\n500,1.2\n"))
        np.testing.assert_array_equal(values, [-0.01, 1.2])

    def test_round_trip_savetxt(self, tmp_path):
        reflectance = spectra.colorchecker("dark skin", WL)
        path = tmp_path / "dark_skin.csv"
        np.savetxt(path, np.column_stack([WL, reflectance]), delimiter=",",
                   header="wavelength,reflectance", fmt="%.17g")
        wl, values = read_spectrum_csv(path)
        np.testing.assert_array_equal(wl, WL)
        np.testing.assert_array_equal(values, reflectance)
        np.testing.assert_array_equal(spectrum_to_grid(wl, values), reflectance)

    def test_missing_file_names_path(self, tmp_path):
        path = tmp_path / "nope.csv"
        with pytest.raises(ValueError, match=r"nope\.csv' does not exist"):
            read_spectrum_csv(path)

    def test_directory(self, tmp_path):
        with pytest.raises(ValueError, match="not a regular file"):
            read_spectrum_csv(tmp_path)

    def test_empty_path_and_wrong_type(self):
        with pytest.raises(ValueError, match="empty"):
            read_spectrum_csv("")
        with pytest.raises(ValueError, match="string or path"):
            read_spectrum_csv(42)  # type: ignore[arg-type]

    def test_unreadable(self, tmp_path, monkeypatch):
        path = write(tmp_path, "400,1\n500,2\n")
        real_open = builtins.open

        def deny(file, *args, **kwargs):
            if os.fspath(file) == str(path):
                raise PermissionError(13, "Permission denied", str(path))
            return real_open(file, *args, **kwargs)

        monkeypatch.setattr(builtins, "open", deny)
        with pytest.raises(ValueError, match=r"spectrum\.csv' cannot be read: Permission denied"):
            read_spectrum_csv(path)

    def test_too_large(self, tmp_path):
        path = tmp_path / "huge.csv"
        with open(path, "wb") as handle:
            handle.truncate(MAX_CSV_BYTES + 1)  # sparse: costs no disk
        with pytest.raises(ValueError, match=r"huge\.csv' is 10\.5 MB; files over 10 MB"):
            read_spectrum_csv(path)

    def test_binary(self, tmp_path):
        with pytest.raises(ValueError, match="not a text file"):
            read_spectrum_csv(write(tmp_path, b"400,1\n\x00\x01500,2\n"))

    @pytest.mark.parametrize("text, count", [("400,1,2\n500,1,2\n", 3), ("400\n500\n", 1),
                                             ("400;1;2\n", 3)])
    def test_not_two_columns(self, tmp_path, text, count):
        with pytest.raises(ValueError, match=rf"line 1: expected two columns .* found {count}"):
            read_spectrum_csv(write(tmp_path, text))

    def test_decimal_comma_with_comma_separator(self, tmp_path):
        with pytest.raises(ValueError, match="found 3; a decimal comma needs ';' or tab"):
            read_spectrum_csv(write(tmp_path, "400,0,5\n500,0,6\n"))

    def test_non_numeric_value(self, tmp_path):
        with pytest.raises(ValueError, match=r"line 3, value: 'high' is not a number"):
            read_spectrum_csv(write(tmp_path, "nm,v\n400,0.1\n500,high\n"))

    def test_text_after_data(self, tmp_path):
        with pytest.raises(ValueError, match=r"line 3: 'end' is not a wavelength"):
            read_spectrum_csv(write(tmp_path, "400,0.1\n500,0.2\nend,of data\n"))

    @pytest.mark.parametrize("field", ["nan", "inf", "-inf", "1e400"])
    def test_non_finite(self, tmp_path, field):
        with pytest.raises(ValueError, match=r"line 2, value: .* is not finite"):
            read_spectrum_csv(write(tmp_path, f"400,0.1\n500,{field}\n"))

    @pytest.mark.parametrize("text, rows", [("", 0), ("# only a comment\n", 0),
                                            ("wavelength,value\n", 0), ("400,1\n", 1)])
    def test_fewer_than_two_rows(self, tmp_path, text, rows):
        with pytest.raises(ValueError, match=rf"has {rows} data line\(s\)"):
            read_spectrum_csv(write(tmp_path, text))

    def test_duplicate_wavelength(self, tmp_path):
        with pytest.raises(ValueError, match=r"wavelength 450 nm appears twice \(lines 3 and 4\)"):
            read_spectrum_csv(write(tmp_path, "h\n400,1\n450,2\n450,3\n500,4\n"))

    def test_non_monotonic(self, tmp_path):
        with pytest.raises(ValueError, match=r"line 3: wavelength 420 nm after 450 nm"):
            read_spectrum_csv(write(tmp_path, "400,1\n450,2\n420,3\n500,4\n"))

    def test_micrometres(self, tmp_path):
        with pytest.raises(ValueError, match=r"0\.38–0\.78 look like micrometres"):
            read_spectrum_csv(write(tmp_path, "0.38,1\n0.58,2\n0.78,3\n"))

    def test_not_positive(self, tmp_path):
        with pytest.raises(ValueError, match="must be positive"):
            read_spectrum_csv(write(tmp_path, "-5,1\n400,2\n"))

    def test_misses_visible_range(self, tmp_path):
        with pytest.raises(ValueError, match=r"3800–7800 nm miss the visible range"):
            read_spectrum_csv(write(tmp_path, "3800,1\n7800,2\n"))

    def test_fuzz_random_bytes(self, tmp_path):
        rng = np.random.default_rng(99)
        path = tmp_path / "junk.csv"
        for _ in range(300):
            path.write_bytes(rng.integers(0, 256, size=int(rng.integers(0, 400)),
                                          dtype=np.uint8).tobytes())
            with pytest.raises(ValueError):
                read_spectrum_csv(path)

    def test_fuzz_mutated_csv(self, tmp_path):
        """Plausible files with random damage: either a valid spectrum or a ValueError."""
        rng = np.random.default_rng(5)
        junk = ["", "x", "nan", "inf", "1e999", ",", ";;", "\t", "#", "450", "0,5", "\ufeff",
                "\x00", "µm", "-", ".", "1,2,3", "0.5 0.6", "\r"]
        path = tmp_path / "mutated.csv"
        outcomes = {"ok": 0, "error": 0}
        for _ in range(1500):
            count = int(rng.integers(0, 12))
            wl = np.sort(rng.integers(200, 1000, size=count)) * rng.choice([1.0, 1e-3, -1.0])
            sep = rng.choice([",", ";", "\t", " ", ", "])
            lines = [f"{w:g}{sep}{rng.normal():.4g}" for w in wl]
            for i in range(len(lines)):
                if rng.random() < 0.15:
                    lines[i] = rng.choice(junk) + rng.choice([lines[i], "", sep])
            if rng.random() < 0.5:
                lines.insert(0, "wavelength" + sep + "value")
            path.write_bytes("\n".join(lines).encode(rng.choice(["utf-8", "utf-16"])))
            try:
                wl_read, values = read_spectrum_csv(path)
            except ValueError:
                outcomes["error"] += 1
                continue
            outcomes["ok"] += 1
            assert_valid_spectrum(wl_read, values)
            assert wl_read.size >= 2
        assert min(outcomes.values()) > 100  # both paths are exercised


    def test_errors_are_spectrum_file_errors(self, tmp_path):
        assert issubclass(SpectrumFileError, ValueError)
        for text in ("400,1\n", "400,x\n500,1\n500,2\n", "400,1\n450,nan\n"):
            path = write(tmp_path, text)
            with pytest.raises(SpectrumFileError) as info:
                read_spectrum_csv(path)
            assert str(path) in str(info.value)

    @pytest.mark.parametrize("text, match", [
        ("400,0.1\n500,1e308\n", r"line 2, value: '1e308' is beyond ±1e\+30"),
        ("400,-1e31\n500,0.2\n", r"line 1, value: '-1e31' is beyond"),
        ("400;0,1\n500;2e300\n", r"line 2, value: '2e300' is beyond"),
        ("400,0.1\n1e308,0.2\n", r"line 2, wavelength: '1e308' is beyond"),
        ("400,0.1\n2e5,0.2\n", r"400–200000 nm reach outside 10–100000 nm"),
        ("5,0.1\n500,0.2\n", r"5–500 nm reach outside 10–100000 nm"),
    ])
    def test_extreme_values_and_wavelengths_refused(self, tmp_path, text, match):
        path = write(tmp_path, text)
        with pytest.raises(SpectrumFileError, match=match) as info:
            read_spectrum_csv(path)
        assert str(path) in str(info.value)

    def test_values_and_wavelengths_at_the_limits(self, tmp_path):
        wl, values = read_spectrum_csv(write(tmp_path, "10,1e30\n500,-1e30\n1e5,0\n"))
        np.testing.assert_array_equal(wl, [10.0, 500.0, 1e5])
        np.testing.assert_array_equal(values, [1e30, -1e30, 0.0])

    def test_too_many_rows(self, tmp_path):
        rows = [f"{400 + i * 1e-3:.3f},1\n" for i in range(MAX_CSV_ROWS + 1)]
        path = write(tmp_path, "".join(rows))
        with pytest.raises(SpectrumFileError, match=rf"line {MAX_CSV_ROWS + 1}: more than "
                                                    r"100,000 samples"):
            read_spectrum_csv(path)
        # a header line, then exactly MAX_CSV_ROWS samples: read
        path = write(tmp_path, "wl,v\n" + "".join(rows[:-1]), "most.csv")
        assert read_spectrum_csv(path)[0].size == MAX_CSV_ROWS

    def test_many_fields_on_one_line(self, tmp_path):
        with pytest.raises(SpectrumFileError, match=r"line 1: .* found over 8$"):
            read_spectrum_csv(write(tmp_path, "400" + ",1" * 100_000 + "\n500,1\n"))
        text = "400,0.5" + "," * 50 + "\n500;0,6;;;;;;;;;\n"
        np.testing.assert_array_equal(read_spectrum_csv(write(tmp_path, text))[1], [0.5, 0.6])
        with pytest.raises(SpectrumFileError, match="found over 8"):
            read_spectrum_csv(write(tmp_path, "400 1 2 3 4 5 6 7 8\n500 1\n"))

    def test_long_token_is_fast_and_quoted_short(self, tmp_path):
        path = write(tmp_path, "400,0.5\n500," + "9" * 200_000 + "x\n")
        start = time.perf_counter()
        with pytest.raises(SpectrumFileError, match="line 2, value: '9999") as info:
            read_spectrum_csv(path)
        assert time.perf_counter() - start < 1.0 and len(str(info.value)) < 400

    @pytest.mark.parametrize("brk", ["\r\n", "\r", "\v", "\f", "\x1c", "\x85", "\u2028"])
    def test_line_breaks_as_splitlines(self, tmp_path, brk):
        text = f"wl,v{brk}400,0.1{brk}# note{brk}{brk}500,0.2{brk}x"
        path = write(tmp_path, text, encoding="utf-16")
        with pytest.raises(SpectrumFileError, match="line 6: 'x' is not a wavelength"):
            read_spectrum_csv(path)
        path = write(tmp_path, text[: -len(brk) - 1], "ok.csv", encoding="utf-16")
        np.testing.assert_array_equal(read_spectrum_csv(path)[1], [0.1, 0.2])

    def test_fuzz_errors_name_the_file(self, tmp_path):
        """Mutated files, extreme numbers among the damage: a valid spectrum within the
        limits, or a SpectrumFileError naming the file; nothing else."""
        rng = np.random.default_rng(8)
        junk = ["1e308", "-1e31", "1e30", "3e38", "1e400", "nan", "5", "2e5", "9" * 500 + "x",
                ",,,,,,,,,,,", "0,5", "\x85", "\u2028", "#", "x"]
        path = tmp_path / "fuzz.csv"
        outcomes = {"ok": 0, "error": 0}
        for _ in range(600):
            wl = np.sort(rng.choice(np.arange(380, 781), size=int(rng.integers(2, 10)),
                                    replace=False))
            sep = str(rng.choice([",", ";", "\t", " "]))
            cells = [[f"{w}", f"{rng.uniform(0, 1):.3f}"] for w in wl]
            for _ in range(int(rng.integers(0, 3))):
                row = cells[int(rng.integers(0, len(cells)))]
                row[int(rng.integers(0, 2))] = str(rng.choice(junk))
            path.write_bytes("\n".join(sep.join(c) for c in cells).encode("utf-8"))
            try:
                wl_read, values = read_spectrum_csv(path)
            except SpectrumFileError as exc:
                assert str(path) in str(exc)
                outcomes["error"] += 1
                continue
            outcomes["ok"] += 1
            assert_valid_spectrum(wl_read, values)
            assert np.abs(values).max() <= 1e30 and 10 <= wl_read[0] and wl_read[-1] <= 1e5
        assert min(outcomes.values()) > 100, outcomes


class TestBlackbody:
    @pytest.mark.parametrize("temperature", [500.0, 1500.0, 2856.0, 6504.0, 20000.0, 1e6])
    def test_against_planck_by_hand(self, temperature):
        wl = np.array([380.0, 450.0, 560.0, 620.0, 780.0])
        got = blackbody_spd(temperature, wl)
        expected = planck_by_hand(wl, temperature, 1.4388e-2) / planck_by_hand(
            560.0, temperature, 1.4388e-2)
        np.testing.assert_allclose(got, expected, rtol=1e-12)
        # CODATA's c₂ = hc/k = 1.438777e-2 m·K differs from CIE's rounded 1.4388e-2, which
        # moves ln(ratio) by Δc₂ · |1/λ − 1/560 nm| / T at most.
        codata = planck_by_hand(wl, temperature) / planck_by_hand(560.0, temperature)
        delta_c2 = abs(1.4388e-2 - H_PLANCK * C_LIGHT / K_BOLTZMANN)
        bound = delta_c2 * np.max(np.abs(1 / (wl * 1e-9) - 1 / 560e-9)) / temperature
        np.testing.assert_allclose(got, codata, rtol=1.01 * bound + 1e-12)

    def test_ratio_of_two_wavelengths(self):
        spd = blackbody_spd(3000.0, np.array([450.0, 650.0]))
        ratio = (650.0 / 450.0) ** 5 * np.expm1(1.4388e-2 / (650e-9 * 3000.0)) / np.expm1(
            1.4388e-2 / (450e-9 * 3000.0))
        assert spd[0] / spd[1] == pytest.approx(ratio, rel=1e-12)

    def test_6504_k_matches_colour(self):
        sd = colour.sd_blackbody(6504.0, colour.SpectralShape(380, 780, 5))
        reference = sd.values / sd[560]
        np.testing.assert_allclose(blackbody_spd(6504.0, WL), reference, rtol=1e-10)
        np.testing.assert_allclose(blackbody_spd(6504), reference, rtol=1e-10)  # default grid

    def test_normalised_at_560(self):
        for temperature in (500, 2700.5, np.float32(5000), np.int64(10_000)):
            assert blackbody_spd(temperature, np.array([560.0]))[0] == pytest.approx(1.0,
                                                                                     rel=1e-14)

    def test_wien_peak(self):
        wl = np.arange(380.0, 781.0, 0.5)
        peak = wl[np.argmax(blackbody_spd(5000.0, wl))]
        assert peak == pytest.approx(2.897771955e-3 / 5000.0 * 1e9, abs=0.5)  # 579.6 nm

    @pytest.mark.parametrize("temperature", [499.9, 1e6 + 1, -6500, 0, np.nan, np.inf, -np.inf])
    def test_temperature_out_of_range(self, temperature):
        with pytest.raises(ValueError, match="blackbody temperature must be finite and within"):
            blackbody_spd(temperature, WL)

    @pytest.mark.parametrize("temperature", ["6500", None, True, [6500]])
    def test_temperature_not_a_number(self, temperature):
        with pytest.raises(ValueError, match="must be a number"):
            blackbody_spd(temperature, WL)

    def test_bad_wavelengths(self):
        with pytest.raises(ValueError, match="strictly increasing"):
            blackbody_spd(5000, np.array([500.0, 400.0]))


class TestChecks:
    def test_reflectance_ok(self):
        got = check_reflectance([0, 0.5, 1], "albedo")
        assert got.dtype == np.float64
        np.testing.assert_array_equal(got, [0.0, 0.5, 1.0])

    def test_reflectance_out_of_range_reports_count_and_wavelength(self):
        values = spectra.colorchecker(1, WL).copy()
        values[[10, 20, 30]] = [1.2, -0.1, 1.01]
        with pytest.raises(ValueError, match=r"^patch: 3 of 81 values are outside the "
                                             r"reflectance range \[0, 1\]; the first is 1\.2 "
                                             r"at 430 nm$"):
            check_reflectance(values, "patch", WL)

    def test_reflectance_without_wavelengths_gives_index(self):
        with pytest.raises(ValueError, match=r"1 of 3 values .* the first is 2 at sample 2"):
            check_reflectance([0.1, 0.2, 2.0], "albedo")

    def test_reflectance_non_finite(self):
        with pytest.raises(ValueError, match=r"2 of 3 values are NaN or inf; .* at 500 nm"):
            check_reflectance([0.1, np.nan, np.inf], "albedo", [400, 500, 600])

    @pytest.mark.parametrize("values", [[], [[0.1, 0.2]], 0.5])
    def test_shape(self, values):
        with pytest.raises(ValueError, match="non-empty 1-D"):
            check_reflectance(values, "albedo")

    def test_not_numbers_and_mismatched_wavelengths(self):
        with pytest.raises(ValueError, match="not numbers"):
            check_spd(["a", "b"], "lamp")
        with pytest.raises(ValueError, match="3 values but wavelengths of shape"):
            check_spd([1, 2, 3], "lamp", [400, 500])

    def test_spd_ok(self):
        np.testing.assert_array_equal(check_spd(spectra.illuminant("FL2", WL), "FL2"),
                                      spectra.illuminant("FL2", WL))
        check_spd([0.0, 0.0, 1e-9], "lamp")

    def test_spd_negative(self):
        with pytest.raises(ValueError, match=r"lamp: 1 of 3 values are negative; the first is "
                                             r"-1 at 450 nm"):
            check_spd([1, -1, 2], "lamp", [400, 450, 500])

    def test_spd_all_zero(self):
        with pytest.raises(ValueError, match="lamp: every value is zero"):
            check_spd(np.zeros(5), "lamp")

    def test_spd_non_finite(self):
        with pytest.raises(ValueError, match="NaN or inf"):
            check_spd([1.0, np.nan], "lamp")


class TestSpectrumToGrid:
    def test_exact_at_nodes_linear_between(self):
        wl = np.array([400.0, 500.0, 600.0])
        values = np.array([0.0, 1.0, 0.5])
        grid = np.array([400.0, 450.0, 500.0, 575.0, 600.0])
        np.testing.assert_allclose(spectrum_to_grid(wl, values, grid),
                                   [0.0, 0.5, 1.0, 0.625, 0.5], rtol=0, atol=1e-15)

    def test_constant_extrapolation(self):
        got = spectrum_to_grid([500.0, 600.0], [0.2, 0.4], WL)
        assert np.all(got[WL <= 500] == 0.2) and np.all(got[WL >= 600] == 0.4)

    def test_single_sample_is_constant(self):
        np.testing.assert_array_equal(spectrum_to_grid([555.0], [0.3], WL), np.full(81, 0.3))

    def test_default_grid_and_reuse_of_spectrum_values(self):
        wl, values = spectra.colorchecker_spectrum(5)
        np.testing.assert_array_equal(spectrum_to_grid(wl, values),
                                      spectra.spectrum_values((wl, values), WL))

    def test_text_to_grid_round_trip(self):
        wl, values = parse_spectrum_text("380:0.1, 580:0.5, 780:0.9")
        np.testing.assert_allclose(spectrum_to_grid(wl, values, WL), 0.1 + 0.002 * (WL - 380),
                                   rtol=0, atol=1e-15)

    @pytest.mark.parametrize("wl, values", [([400, 500], [1.0]), ([], []),
                                            ([[400, 500]], [[1, 2]])])
    def test_shapes(self, wl, values):
        with pytest.raises(ValueError, match="equal, non-zero length"):
            spectrum_to_grid(wl, values, WL)

    def test_not_increasing_and_non_finite(self):
        with pytest.raises(ValueError, match="strictly increasing"):
            spectrum_to_grid([500, 400], [1, 2], WL)
        with pytest.raises(ValueError, match="finite"):
            spectrum_to_grid([400, 500], [1, np.nan], WL)

    def test_bad_grid(self):
        with pytest.raises(ValueError, match="strictly increasing"):
            spectrum_to_grid([400, 500], [1, 2], [500.0, 400.0])

"""Table 3.2 of the thesis: 19 codes, size-major."""

from perception.codes import EMPTY_CODE, code_of_cell, decode, observation_code, size_class


def test_table_3_2_spot_checks():
    assert observation_code("small", "transparent") == 1
    assert observation_code("small", "green") == 6
    assert observation_code("medium", "brown") == 8
    assert observation_code("large", "blue") == 16
    assert observation_code("large", "green") == 18


def test_roundtrip_all_codes():
    for code in range(1, 19):
        size, colour = decode(code)
        assert observation_code(size, colour) == code
    assert decode(EMPTY_CODE) is None


def test_size_thresholds():
    assert size_class(0.005) is None
    assert size_class(0.25) == "small"
    assert size_class(0.26) == "medium"
    assert size_class(0.65) == "medium"
    assert size_class(0.9) == "large"
    assert code_of_cell(0.0, "red") == EMPTY_CODE

"""The states of an MDEM cluster and of its contacts (integer codes in the state arrays)."""

__all__ = ["BONDED", "FAILED_SHEAR", "FAILED_TENSILE", "INTACT", "INTERFACE", "OPEN", "PRESET",
           "SLIP", "STICK"]

# cluster states: intact, failed in tension or shear, on a plane of weakness, preset crack
INTACT, FAILED_TENSILE, FAILED_SHEAR, INTERFACE, PRESET = 0, 1, 2, 3, 4
# contact states of a failed cluster
BONDED, STICK, SLIP, OPEN = 0, 1, 2, 3

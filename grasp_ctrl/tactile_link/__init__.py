"""The serial link to the fingertip sensor bridge (protocol v1, docs/design.md 5.3).

- ``protocol``: frame layout, CRC, the reference encoder.
- ``decoder``: incremental, resynchronising decoders for the binary and text modes.
- ``serial_sensors``: ``SerialSensors``, the pyserial ``SensorBackend``.
- ``recorder``: CSV recording of every valid frame.

The byte-level specification a firmware author implements is docs/tactile_protocol.md.
"""

from grasp_ctrl.tactile_link.decoder import BinaryDecoder, DecodedFrame, TextDecoder, make_decoder
from grasp_ctrl.tactile_link.protocol import crc16_ccitt_false, encode_binary, encode_text

__all__ = [
    "BinaryDecoder",
    "DecodedFrame",
    "TextDecoder",
    "make_decoder",
    "crc16_ccitt_false",
    "encode_binary",
    "encode_text",
]

"""Wire constants of the twin's I2C socket (protocol/i2c-socket.md), shared by the host's client
(``jackson.host.actuation.i2c``) and the twin's server (``jackson.sim.i2c_server``)."""

OP_WRITE_BYTE_DATA = 0x01
OP_READ_BYTE_DATA = 0x02
OP_WRITE_I2C_BLOCK_DATA = 0x03
OP_READ_I2C_BLOCK_DATA = 0x04
STATUS_OK = 0
STATUS_NACK = 1
STATUS_BAD_REQUEST = 2
REQUEST_HEADER_SIZE = 4  # op, addr, reg, len
RESPONSE_HEADER_SIZE = 2  # status, len
MAX_BLOCK = 32  # bytes in one i2c block transfer (I2C_SMBUS_BLOCK_MAX)
MAX_ADDRESS = 0x7F  # 7-bit addressing

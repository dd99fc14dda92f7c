"""Writes warehouse.png (run from this folder): a 300 × 150 px occupancy
image at 0.2 m/px (60 × 30 m); black = shelves and walls, white = free."""
import struct
import zlib

W, H = 300, 150
img = [[255] * W for _ in range(H)]
def block(x0, y0, x1, y1):  # metres, y up
    for y in range(int(y0 / 0.2), int(y1 / 0.2)):
        for x in range(int(x0 / 0.2), int(x1 / 0.2)):
            img[H - 1 - y][x] = 0
block(0, 0, 60, 1); block(0, 29, 60, 30); block(0, 0, 1, 30); block(59, 0, 60, 30)  # walls
for i in range(4):  # shelves
    block(12 + i * 10, 1, 15 + i * 10, 20) if i % 2 == 0 else block(12 + i * 10, 10, 15 + i * 10, 29)
def chunk(kind, data):
    c = kind + data
    return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)
raw = b"".join(b"\x00" + bytes(row) for row in img)
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", W, H, 8, 0, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
open("warehouse.png", "wb").write(png)

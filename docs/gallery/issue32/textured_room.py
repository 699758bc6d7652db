# Writes the textured test room of docs/gallery/issue32/textures.md (room.obj, room.mtl, checker/painting/crate PNGs) into the current folder.
import zlib, struct, math
def png(path, w, h, px):
    raw = b''.join(b'\x00' + bytes(sum((list(px(x, y)) for x in range(w)), [])) for y in range(h))
    def chunk(t, d): return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
    open(path, 'wb').write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0)) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b''))
png('checker.png', 64, 64, lambda x, y: (235, 230, 220) if (x // 8 + y // 8) % 2 == 0 else (40, 45, 60))
def painting(x, y):
    # sky, a sun at the top left, green hills below (image rows from the top)
    if (x - 16) ** 2 + (y - 14) ** 2 < 64: return (255, 210, 40)
    hill = 40 + 6 * math.sin(x / 9.0)
    if y > hill: return (40, 140, 50)
    return (90, 150, 230)
png('painting.png', 64, 64, painting)
png('crate.png', 32, 32, lambda x, y: (180, 110, 50) if (x % 16 < 2 or y % 16 < 2 or abs((x % 16) - (y % 16)) < 2) else (120, 70, 30))

V, VT, out = [], [], []
def grid(origin, du, dv, n, mtl, su=1.0, sv=1.0):
    out.append(f'usemtl {mtl}')
    base, tbase = len(V), len(VT)
    for j in range(n + 1):
        for i in range(n + 1):
            V.append(tuple(origin[k] + du[k] * i / n + dv[k] * j / n for k in range(3)))
            VT.append((su * i / n, sv * j / n))
    for j in range(n):
        for i in range(n):
            a = base + j * (n + 1) + i + 1; b = a + 1; c = a + n + 2; d = a + n + 1
            ta = tbase + j * (n + 1) + i + 1; tb = ta + 1; tc = ta + n + 2; td = ta + n + 1
            out.append(f'f {a}/{ta} {b}/{tb} {c}/{tc}'); out.append(f'f {a}/{ta} {c}/{tc} {d}/{td}')
n = 16
grid((-1, 0, 1), (2, 0, 0), (0, 0, -2), n, 'floor')
grid((-1, 2, -1), (2, 0, 0), (0, 0, 2), n, 'white')
grid((-1, 0, -1), (2, 0, 0), (0, 2, 0), n, 'painting')
grid((-1, 0, -1), (0, 2, 0), (0, 0, 2), n, 'red')
grid((1, 0, -1), (0, 0, 2), (0, 2, 0), n, 'green')
# crate: 0.6 m cube, outward faces
o, s, m = (0.1, 0.0, -0.6), 0.6, 6
x0, y0, z0 = o; x1, y1, z1 = x0 + s, y0 + s, z0 + s
grid((x0, y0, z1), (s, 0, 0), (0, s, 0), m, 'crate')      # front +z
grid((x1, y0, z0), (-s, 0, 0), (0, s, 0), m, 'crate')     # back -z
grid((x1, y0, z1), (0, 0, -s), (0, s, 0), m, 'crate')     # right +x
grid((x0, y0, z0), (0, 0, s), (0, s, 0), m, 'crate')      # left -x
grid((x0, y1, z1), (s, 0, 0), (0, 0, -s), m, 'crate')     # top +y
with open('room.obj', 'w') as f:
    f.write('mtllib room.mtl\n')
    f.writelines(f'v {x:.6g} {y:.6g} {z:.6g}\n' for x, y, z in V)
    f.writelines(f'vt {u:.6g} {v:.6g}\n' for u, v in VT)
    f.write('\n'.join(out) + '\n')
mtl = {'floor': ('0.8 0.8 0.8', 'checker.png'), 'white': ('0.75 0.75 0.75', None), 'painting': ('0.9 0.9 0.9', 'painting.png'),
       'red': ('0.6 0.08 0.08', None), 'green': ('0.1 0.5 0.1', None), 'crate': ('0.9 0.9 0.9', 'crate.png')}
for name, textured in [('room.mtl', True), ('room_untextured.mtl', False)]:
    with open(name, 'w') as f:
        for k, (kd, tex) in mtl.items():
            f.write(f'newmtl {k}\nKd {kd}\n' + (f'map_Kd {tex}\n' if tex and textured else '') + '\n')

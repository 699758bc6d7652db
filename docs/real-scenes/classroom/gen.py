# A classroom-like test scene: a 10 x 8 x 3 m room of thick walls with three
# windows, standing on a 220 m ground plane (two triangles, which is also
# the room's floor), under a sky; two rows of desks (boxes, one pair
# overlapping as modelled furniture often does).
V=[]; F=[]
def box(lo,hi,mat):
    x0,y0,z0=lo; x1,y1,z1=hi
    b=len(V)+1
    for x,y,z in [(x0,y0,z0),(x1,y0,z0),(x1,y1,z0),(x0,y1,z0),(x0,y0,z1),(x1,y0,z1),(x1,y1,z1),(x0,y1,z1)]:
        V.append((x,y,z))
    q=[(0,3,2,1),(4,5,6,7),(0,1,5,4),(3,7,6,2),(0,4,7,3),(1,2,6,5)]  # outward (ccw seen from outside)
    for a,bb,c,d in q:
        F.append((mat,b+a,b+bb,b+c)); F.append((mat,b+a,b+c,b+d))
def quad(p0,p1,p2,p3,mat):
    b=len(V)+1
    V.extend([p0,p1,p2,p3]); F.append((mat,b,b+1,b+2)); F.append((mat,b,b+2,b+3))
G=110.0
quad((-G,0,G),(G,0,G),(G,0,-G),(-G,0,-G),'ground')   # up-facing
t=0.2
# north (z=8), east, west walls full; south wall (z=0) with windows
box((0,0,8),(10,3,8+t),'wall'); box((-t,0,-t),(0,3,8+t),'wall'); box((10,0,-t),(10+t,3,8+t),'wall')
box((0,0,-t),(10,0.9,0),'wall'); box((0,2.1,-t),(10,3,0),'wall')
for x0,x1 in [(0,1.5),(3.5,4),(6,6.5),(8.5,10)]:
    box((x0,0.9,-t),(x1,2.1,0),'wall')
box((-t,3,-t),(10+t,3+t,8+t),'ceiling')
for row in range(3):
    for col in range(3):
        x=1.5+col*3; z=2.5+row*1.8
        box((x,0.7,z),(x+1.6,0.75,z+0.6),'desk')
        box((x+0.05,0,z+0.05),(x+0.15,0.7,z+0.15),'desk'); box((x+1.45,0,z+0.05),(x+1.55,0.7,z+0.15),'desk')
        box((x+0.05,0,z+0.45),(x+0.15,0.7,z+0.55),'desk'); box((x+1.45,0,z+0.45),(x+1.55,0.7,z+0.55),'desk')
# the teacher's desk: two overlapping boxes (corners of one buried in the other)
box((4,0,6.6),(6,0.75,7.2),'desk'); box((5.5,0,6.4),(6.6,0.8,7.3),'desk')
with open('classroom.obj','w') as o:
    o.write('mtllib classroom.mtl\n')
    for v in V: o.write('v %g %g %g\n'%v)
    cur=None
    for m,a,b,c in F:
        if m!=cur: o.write('usemtl %s\n'%m); cur=m
        o.write('f %d %d %d\n'%(a,b,c))
open('classroom.mtl','w').write('''newmtl ground
Kd 0.3 0.35 0.2
newmtl wall
Kd 0.75 0.73 0.7
newmtl ceiling
Kd 0.8 0.8 0.8
newmtl desk
Kd 0.55 0.38 0.22
''')
open('classroom.toml','w').write('''[camera]
position = [9.2, 1.6, 7.5]
target = [3.0, 1.0, 0.5]
fov_deg = 70
[sky]
zenith = [4, 5, 7]
horizon = [4, 4, 4]
[[mesh]]
obj = "classroom.obj"
''')
print(len(V),'positions',len(F),'triangles')

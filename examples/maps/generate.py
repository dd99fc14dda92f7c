"""Writes litesim's example OpenDRIVE maps (run from the repository root):

    python3 examples/maps/generate.py

straight.xodr  500 m, three driving lanes each way, sidewalks, a cone
circ.xodr      a ring of two one-way half circles (R = 100 m), two lanes
curvy.xodr     line, spiral, arc, spiral, line, paramPoly3; elevation; widening lane
junction.xodr  a four-way junction with twelve connecting roads and traffic lights

Start points of pieces after a spiral are computed here by integrating the
clothoid with 200,000-step Simpson sums (error far below 1e-9 m).
"""
import math
import os

OUT = os.path.dirname(os.path.abspath(__file__))
HEADER = '<?xml version="1.0" encoding="UTF-8"?>\n<OpenDRIVE>\n  <header revMajor="1" revMinor="6" name="{name}" vendor="litesim"/>\n'


def lane(lid, kind="driving", width=3.5, extra=""):
    return (f'          <lane id="{lid}" type="{kind}" level="false">'
            f'<width sOffset="0" a="{width}" b="0" c="0" d="0"/>'
            f'<roadMark sOffset="0" type="{"solid" if kind != "driving" else "broken"}" color="standard" width="0.12"/>{extra}</lane>\n')


def edge_marks(side):
    """The outermost driving lane of a side (next to a sidewalk or the road's
    edge) gets a solid line; lines between driving lanes stay broken."""
    out = list(side)
    for i, l in enumerate(out):
        outer_is_driving = i + 1 < len(out) and 'type="driving"' in out[i + 1]
        if 'type="driving"' in l and not outer_is_driving:
            out[i] = l.replace('type="broken" color', 'type="solid" color')
    return out


def lanes(left, right, offset=None, section_extra="", marks=True):
    """A lane section. Two-way roads get a solid yellow centre line, one-way
    roads a solid white left edge; `marks=False` (junction connecting roads)
    paints nothing."""
    left, right = edge_marks(left), edge_marks(right)
    if left and right:
        centre = 'type="solid" color="yellow"'
    else:
        centre = 'type="solid" color="standard"'
    if not marks:
        centre = 'type="none" color="standard"'
        left = [l.replace('type="broken"', 'type="none"').replace('type="solid"', 'type="none"') for l in left]
        right = [l.replace('type="broken"', 'type="none"').replace('type="solid"', 'type="none"') for l in right]
    out = "    <lanes>\n"
    if offset is not None:
        out += f'      <laneOffset s="0" a="{offset}" b="0" c="0" d="0"/>\n'
    out += '      <laneSection s="0">\n'
    if left:
        out += "        <left>\n" + "".join(left) + "        </left>\n"
    out += f'        <center>\n          <lane id="0" type="none" level="false"><roadMark sOffset="0" {centre} width="0.12"/></lane>\n        </center>\n'
    if right:
        out += "        <right>\n" + "".join(right) + "        </right>\n"
    out += "      </laneSection>\n" + section_extra + "    </lanes>\n"
    return out


def road(rid, length, geoms, lanes_xml, junction="-1", link="", extra="", rtype="town"):
    return (f'  <road id="{rid}" name="road {rid}" length="{length!r}" junction="{junction}" rule="RHT">\n'
            f"    <link>{link}</link>\n"
            f'    <type s="0" type="{rtype}"><speed max="50" unit="km/h"/></type>\n'
            f"    <planView>\n{geoms}    </planView>\n{lanes_xml}{extra}  </road>\n")


def geom(s, x, y, h, length, shape):
    return f'      <geometry s="{s!r}" x="{x!r}" y="{y!r}" hdg="{h!r}" length="{length!r}">{shape}</geometry>\n'


def spiral_end(x, y, h, k0, k1, length, n=200000):
    c = (k1 - k0) / length
    def heading(t):
        return h + k0 * t + 0.5 * c * t * t
    step = length / n
    sx = math.cos(heading(0)) + math.cos(heading(length))
    sy = math.sin(heading(0)) + math.sin(heading(length))
    for i in range(1, n):
        w = 4 if i % 2 else 2
        t = i * step
        sx += w * math.cos(heading(t))
        sy += w * math.sin(heading(t))
    return x + sx * step / 3, y + sy * step / 3, heading(length)


def arc_end(x, y, h, k, length):
    return x + (math.sin(h + k * length) - math.sin(h)) / k, y - (math.cos(h + k * length) - math.cos(h)) / k, h + k * length


def write(name, body):
    with open(os.path.join(OUT, name), "w") as f:
        f.write(HEADER.format(name=name[:-5]) + body + "</OpenDRIVE>\n")


# straight: 3 lanes each way + sidewalks, a cone on the right lane.
right = [lane(-1), lane(-2), lane(-3), lane(-4, "sidewalk", 2.0)]
left = [lane(1), lane(2), lane(3), lane(4, "sidewalk", 2.0)]
cone = '    <objects>\n      <object id="cone1" type="obstacle" name="cone" s="250" t="-5.25" zOffset="0" hdg="0" radius="0.3" height="0.7"/>\n    </objects>\n'
write("straight.xodr", road("1", 500.0, geom(0.0, 0.0, 0.0, 0.0, 500.0, "<line/>"), lanes(left, right), extra=cone))

# circ: two one-way half circles, R = 100 m, counter-clockwise, two right lanes each.
R = 100.0
half = math.pi * R
k = 1.0 / R
g1 = geom(0.0, 0.0, -R, 0.0, half, f'<arc curvature="{k!r}"/>')
g2 = geom(0.0, 0.0, R, math.pi, half, f'<arc curvature="{k!r}"/>')
two = [lane(-1), lane(-2, "driving", 3.5, '<link><predecessor id="-2"/><successor id="-2"/></link>')]
two[0] = lane(-1, "driving", 3.5, '<link><predecessor id="-1"/><successor id="-1"/></link>')
link1 = '<predecessor elementType="road" elementId="2" contactPoint="end"/><successor elementType="road" elementId="2" contactPoint="start"/>'
link2 = '<predecessor elementType="road" elementId="1" contactPoint="end"/><successor elementType="road" elementId="1" contactPoint="start"/>'
write("circ.xodr", road("1", half, g1, lanes([], two), link=link1) + road("2", half, g2, lanes([], two), link=link2))

# curvy: line 100, spiral 0→0.02 over 60, arc 0.02 over 80, spiral 0.02→0 over 60, line 100, paramPoly3 50.
pieces = []
x, y, h, s = 0.0, 0.0, 0.0, 0.0
pieces.append(geom(s, x, y, h, 100.0, "<line/>")); x, y, s = x + 100.0, y, s + 100.0
pieces.append(geom(s, x, y, h, 60.0, '<spiral curvStart="0.0" curvEnd="0.02"/>')); x, y, h = spiral_end(x, y, h, 0.0, 0.02, 60.0); s += 60.0
pieces.append(geom(s, x, y, h, 80.0, '<arc curvature="0.02"/>')); x, y, h = arc_end(x, y, h, 0.02, 80.0); s += 80.0
pieces.append(geom(s, x, y, h, 60.0, '<spiral curvStart="0.02" curvEnd="0.0"/>')); x, y, h = spiral_end(x, y, h, 0.02, 0.0, 60.0); s += 60.0
pieces.append(geom(s, x, y, h, 100.0, "<line/>")); x, y = x + 100.0 * math.cos(h), y + 100.0 * math.sin(h); s += 100.0
pieces.append(geom(s, x, y, h, 50.0, '<paramPoly3 aU="0" bU="1" cU="0" dU="0" aV="0" bV="0" cV="0.002" dV="0" pRange="arcLength"/>')); s += 50.0
curvy_right = [lane(-1), '          <lane id="-2" type="driving" level="false"><width sOffset="0" a="3.0" b="0.0" c="0.00003" d="0.0"/></lane>\n']
elev = '    <elevationProfile><elevation s="0" a="0" b="0.01" c="0" d="0"/><elevation s="200" a="2" b="0.01" c="-0.0001" d="0"/></elevationProfile>\n'
body = road("1", s, "".join(pieces), lanes([lane(1), lane(2)], curvy_right), rtype="rural")
body = body.replace("    </planView>\n", "    </planView>\n" + elev)
write("curvy.xodr", body)

# junction: four arms of 100 m ending at a 20 x 20 m box; lane -1 enters, lane 1 leaves.
def rot(px, py, a):
    return px * math.cos(a) - py * math.sin(a), px * math.sin(a) + py * math.cos(a)

out = ""
arms = []
for k in range(4):
    a = k * math.pi / 2
    sx, sy = rot(-110.0, 0.0, a)
    rid = str(k + 1)
    arms.append(rid)
    sig = (f'    <signals>\n      <signal s="95" t="-4.5" id="tl{rid}" name="light {rid}" dynamic="yes" orientation="+" zOffset="3" '
           f'country="OpenDRIVE" type="1000001" subtype="-1" value="-1" height="1" width="0.4"><validity fromLane="-1" toLane="-1"/></signal>\n    </signals>\n')
    out += road(rid, 100.0, geom(0.0, sx, sy, a, 100.0, "<line/>"),
                lanes([lane(1), lane(2, "sidewalk", 2.0)], [lane(-1), lane(-2, "sidewalk", 2.0)]),
                link='<successor elementType="junction" elementId="100"/>', extra=sig)
conns = ""
cid = 101
for k in range(4):
    a = k * math.pi / 2
    x0, y0 = rot(-10.0, -1.75, a)
    h0 = a
    # (target arm index, shape): straight, right, left
    for kind in ("straight", "right", "left"):
        if kind == "straight":
            target = (k + 2) % 4; length = 20.0; shape = "<line/>"
        elif kind == "right":
            target = (k + 1) % 4; rr = 8.25; length = rr * math.pi / 2; shape = f'<arc curvature="{-1 / rr!r}"/>'
        else:
            target = (k + 3) % 4; rr = 11.75; length = rr * math.pi / 2; shape = f'<arc curvature="{1 / rr!r}"/>'
        rid = str(cid)
        link = (f'<predecessor elementType="road" elementId="{arms[k]}" contactPoint="end"/>'
                f'<successor elementType="road" elementId="{arms[target]}" contactPoint="end"/>')
        cl = lane(-1, "driving", 3.5, '<link><predecessor id="-1"/><successor id="1"/></link>')
        out += road(rid, length, geom(0.0, x0, y0, h0, length, shape), lanes([], [cl], offset=1.75, marks=False), junction="100", link=link)
        conns += (f'    <connection id="{cid}" incomingRoad="{arms[k]}" connectingRoad="{rid}" contactPoint="start">'
                  f'<laneLink from="-1" to="-1"/></connection>\n')
        cid += 1
out += f'  <junction id="100" name="crossing" type="default">\n{conns}    <controller id="c1"/>\n    <controller id="c2"/>\n  </junction>\n'
out += '  <controller id="c1" name="east-west"><control signalId="tl1" type="0"/><control signalId="tl3" type="0"/></controller>\n'
out += '  <controller id="c2" name="north-south"><control signalId="tl2" type="0"/><control signalId="tl4" type="0"/></controller>\n'
write("junction.xodr", out)
print("wrote", ", ".join(sorted(f for f in os.listdir(OUT) if f.endswith(".xodr"))))

"""A material's Volume output → a ``polychrome.Medium`` (docs/media.md), with constant
inputs, as Cycles defines the volume closures (``svm_node_closure_volume`` and
``svm_node_principled_volume``, intern/cycles/kernel/svm/closure.h;
``volume_extinction_setup`` and ``volume_henyey_greenstein_setup``,
kernel/closure/volume.h):

* Volume Absorption: σa = density·(1 − colour);
* Volume Scatter: σs = density·colour (Henyey–Greenstein phase only);
* Principled Volume: σs = density·colour, σa = density·max(1 − colour, 0)·
  max(1 − √(absorption colour), 0), emission strength × colour per unit length;
* Principled Volume's blackbody: Blackbody Tint × σ_SB·10⁻⁶/π·mix(1, T⁴, Blackbody
  Intensity) × the blackbody colour of T at luminance 1 (Stefan–Boltzmann, as
  ``svm_node_principled_volume``), exported as Planck's spectrum (a tint or other
  emission beside it makes it an RGB colour, as ``spectra.tinted``);
* Emission on the Volume socket: emission per unit length;
* Add Shader sums, Mix Shader (constant factor) blends coefficients.

The world's Volume output is the same (``export_world_volume``): a medium filling all
space. Linked inputs (attributes, textures: heterogeneous media) and other phase
functions are not rendered: one warning each naming the material (or world) and the
node, and the input's own value is used."""

import math

import polychrome as pc


def volume_node(mat):
    """The node on the active Material Output's Volume input, or None."""
    if mat is None or not mat.use_nodes or mat.node_tree is None:
        return None
    out = mat.node_tree.get_output_node("ALL") or mat.node_tree.get_output_node("CYCLES")
    sock = None if out is None else out.inputs.get("Volume")
    while sock is not None and sock.is_linked:
        node = sock.links[0].from_node
        if node.type != "REROUTE":
            return node
        sock = node.inputs[0]
    return None


class _Coefficients:
    """RGB coefficients (σa, σs, emission) and the σs-weighted anisotropy."""

    def __init__(self):
        self.sa = [0.0, 0.0, 0.0]
        self.ss = [0.0, 0.0, 0.0]
        self.em = [0.0, 0.0, 0.0]
        self.g_weight = 0.0
        self.g_sum = 0.0
        self.gs = set()
        # Blackbody emission: (temperature K, RGB tint × Stefan–Boltzmann intensity).
        self.bb = []

    def add(self, other, w):
        for k in range(3):
            self.sa[k] += w * other.sa[k]
            self.ss[k] += w * other.ss[k]
            self.em[k] += w * other.em[k]
        self.g_weight += w * other.g_weight
        self.g_sum += w * other.g_sum
        self.gs |= other.gs
        self.bb += [(t, [w * x for x in k]) for t, k in other.bb]

    def scatter(self, rgb, g):
        for k in range(3):
            self.ss[k] += rgb[k]
        weight = sum(rgb)
        if weight > 0.0:
            self.g_weight += weight
            self.g_sum += weight * g
            self.gs.add(round(g, 6))


#: Stefan–Boltzmann σ·10⁻⁶/π, Cycles' blackbody intensity factor (svm_node_principled_volume).
SIGMA_SB = 5.670373e-8 * 1e-6 / math.pi


class VolumeExport:
    def __init__(self, mat, warnings, kind="material"):
        self.mat, self.warnings = mat, warnings
        self.owner = f"{kind} '{mat.name}'"

    def value(self, node, name, default=0.0):
        sock = node.inputs.get(name)
        if sock is None:  # hidden by the node's options (e.g. a phase without anisotropy)
            return default
        if sock.is_linked:
            self.warnings.add(
                ("volume-input", self.mat.name, node.name, name),
                f"{self.owner}: '{node.name}' {name} is driven by a node (heterogeneous media are not supported); its value is used",
            )
        v = sock.default_value
        if hasattr(v, "__len__"):
            v = [float(c) for c in v[:3]]
            if not all(math.isfinite(c) for c in v):
                raise ValueError(f"{self.owner}: '{node.name}' {name} is not finite")
            return v
        v = float(v)
        if not math.isfinite(v):
            raise ValueError(f"{self.owner}: '{node.name}' {name} is not finite")
        return v

    def node(self, node, depth=0):
        c = _Coefficients()
        if node is None or depth > 32:
            return c
        if node.mute:
            return c
        t = node.type
        if t == "VOLUME_ABSORPTION":
            col, rho = self.value(node, "Color"), max(self.value(node, "Density"), 0.0)
            c.sa = [rho * max(1.0 - x, 0.0) for x in col]
        elif t == "VOLUME_SCATTER":
            col, rho = self.value(node, "Color"), max(self.value(node, "Density"), 0.0)
            phase = getattr(node, "phase", "HENYEY_GREENSTEIN")
            if phase != "HENYEY_GREENSTEIN":
                self.warnings.add(
                    ("volume-phase", self.mat.name, node.name),
                    f"{self.owner}: '{node.name}' phase {phase} is not supported; Henyey-Greenstein is used",
                )
            c.scatter([rho * max(x, 0.0) for x in col], self.value(node, "Anisotropy"))
        elif t == "PRINCIPLED_VOLUME":
            self.principled(node, c)
        elif t == "EMISSION":
            col, s = self.value(node, "Color"), self.value(node, "Strength")
            c.em = [max(x, 0.0) * s for x in col]
        elif t == "ADD_SHADER":
            for sock in node.inputs[:2]:
                if sock.is_linked:
                    c.add(self.node(sock.links[0].from_node, depth + 1), 1.0)
        elif t == "MIX_SHADER":
            f = min(max(self.value(node, "Fac"), 0.0), 1.0)
            for sock, w in ((node.inputs[1], 1.0 - f), (node.inputs[2], f)):
                if sock.is_linked:
                    c.add(self.node(sock.links[0].from_node, depth + 1), w)
        else:
            self.warnings.add(
                ("volume-node", self.mat.name, node.name),
                f"{self.owner}: volume node '{node.name}' ({node.bl_idname}) is not supported and is ignored",
            )
        return c

    def principled(self, node, c):
        col = [max(x, 0.0) for x in self.value(node, "Color")]
        rho = max(self.value(node, "Density"), 0.0)
        absorb = [max(x, 0.0) for x in self.value(node, "Absorption Color")]
        c.scatter([rho * x for x in col], self.value(node, "Anisotropy"))
        c.sa = [rho * max(1.0 - col[k], 0.0) * max(1.0 - math.sqrt(absorb[k]), 0.0) for k in range(3)]
        strength = self.value(node, "Emission Strength")
        if strength > 0.0:
            ec = self.value(node, "Emission Color")
            c.em = [strength * max(x, 0.0) for x in ec]
        blackbody = self.value(node, "Blackbody Intensity")
        if blackbody > 0.0:
            t = max(self.value(node, "Temperature"), 0.0)
            intensity = SIGMA_SB * ((1.0 - blackbody) + blackbody * t**4)
            tint = [max(x, 0.0) for x in self.value(node, "Blackbody Tint", [1.0, 1.0, 1.0])]
            if t > 0.0 and intensity > 0.0 and max(tint) > 0.0:
                c.bb.append((t, [intensity * x for x in tint]))

    def medium(self):
        node = volume_node(self.mat)
        if node is None:
            return None
        c = self.node(node)
        if len(c.gs) > 1:
            self.warnings.add(
                ("volume-g", self.mat.name),
                f"{self.owner}: scattering volumes of different anisotropy are combined with their mean anisotropy",
            )
        if max(c.sa + c.ss + c.em) <= 0.0 and not c.bb:
            return None
        g = c.g_sum / c.g_weight if c.g_weight > 0.0 else 0.0

        # Coefficients as an RGB colour in [0, 1] times a density (the uplift bounds
        # reflectance-like colours), so the largest channel carries the scale.
        def colour(rgb):
            peak = max(rgb)
            return None if peak <= 0.0 else pc.spectra.rgb(*(x / peak for x in rgb)) * peak

        em = _emission(c)
        return pc.Medium(colour(c.sa), colour(c.ss), anisotropy=min(max(g, -0.999), 0.999), emission=em)


def _emission(c):
    """The emission spectrum: RGB, or Planck's spectrum for a lone untinted blackbody;
    several terms are summed as linear Rec.709 colours (a blackbody's own through the CIE
    observer, as ``spectra.tinted``)."""
    from .lights import blackbody_white

    rgb = list(c.em)
    if not any(x > 0.0 for x in rgb) and len(c.bb) == 1 and len(set(c.bb[0][1])) == 1:
        t, k = c.bb[0]
        return blackbody_white(t) * k[0]
    for t, k in c.bb:
        own = pc.spectra.rec709(blackbody_white(t))
        for j in range(3):
            rgb[j] += k[j] * own[j]
    return None if max(rgb) <= 0.0 else pc.spectra.rgb(*rgb)


def export_volume(mat, warnings):
    """The medium of ``mat``'s Volume output, or None."""
    if mat is None or volume_node(mat) is None:
        return None
    return VolumeExport(mat, warnings).medium()


def export_world_volume(world, warnings):
    """The medium of the world's Volume output (fog filling all space), or None."""
    if world is None or volume_node(world) is None:
        return None
    return VolumeExport(world, warnings, "world").medium()

"""The separable pass as GLSL compute shaders: source generation from a plan, and a frame runner that keeps
every image on the GPU between passes (and between frames) and reads back only when asked.

:func:`separable_source` fills the fixed shader ``separable.comp`` (beside this module) with one pass's
constants: the plan's tap rows, centre weights, signs and depth parameters of every slot, baked in as
GLSL constants, so the driver unrolls the loops of a one-material plan. The same source runs here on
any GPU or on llvmpipe, and is what ``ssskit export`` writes as a whole shader.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from typing import TYPE_CHECKING, Any, TypeGuard

import numpy as np

from ...errors import PassError
from ...quantities import Quantity, check_finite
from ...sampling.hashes import frame_base
from ..plan import DEPTH_MODES, SeparablePlan

if TYPE_CHECKING:
    import moderngl



@dataclass(frozen=True)
class Layout:
    """How a pass maps onto the device: the work-group sizes of the horizontal and vertical passes and the
    storage of the images. The result does not depend on it (the tests run every layout)."""

    horizontal: tuple[int, int] = (16, 16)
    vertical: tuple[int, int] = (16, 16)
    #: the storage of the source, intermediate and output images: "texture" (RGBA32F, texelFetch /
    #: imageStore) or "buffer" (std430 buffers of vec4, rows padded)
    storage: tuple[str, str, str] = ("texture", "texture", "texture")

    def __post_init__(self):
        if len(self.storage) != 3 or any(k not in ("texture", "buffer") for k in self.storage):
            raise PassError(f"gl storage must be three of texture/buffer (source, intermediate, output), got {self.storage}")

    def local(self, vertical: bool) -> tuple[int, int]:
        return self.vertical if vertical else self.horizontal


#: measured fastest on an H100 (benchmarks/bench_gl.py, benchmarks/RESULTS.md): the frame and the
#: intermediate image as storage buffers (loads through L1, not the texture units: 0.041 instead of
#: 0.062 ms per 1080p pass), the output a texture; wide groups for the horizontal pass
GPU_LAYOUT = Layout((64, 4), (32, 8), ("buffer", "buffer", "texture"))
#: measured fastest on llvmpipe (Mesa's CPU driver): textures (half the time of buffers there)
CPU_LAYOUT = Layout((16, 16), (16, 16), ("texture", "texture", "texture"))


def default_layout() -> Layout:
    """The layout for this context's device: :data:`CPU_LAYOUT` on llvmpipe, else :data:`GPU_LAYOUT`."""
    from .context import is_software

    return CPU_LAYOUT if is_software() else GPU_LAYOUT
#: slots are stored as 16-bit unsigned integers
MAX_SLOTS = 1 << 16
#: the rule of every gl shader that bakes a plan's per-slot tables: the profile ids of one frame (slots less the
#: no-SSS slot 0); a shader with smaller tables narrows it (:meth:`~ssskit.quantities.Quantity.within`)
GL_PROFILE_IDS = Quantity("the gl backend's profile ids in one frame", 0, MAX_SLOTS - 1, "",
                          "slots are stored as 16-bit unsigned integers", integer=True)


def wrapped(wrapper: str, body: str) -> str:
    """The shader ``wrapper`` (a file beside this module: the compute or the fragment form) with the per-pixel
    body ``body`` (a file beside it, one source for both forms) inserted at its ``// @BODY@`` marker."""
    files = resources.files(__package__)
    text = files.joinpath(wrapper).read_text(encoding="utf-8")  # (each shipped wrapper holds the marker)
    return text.replace("// @BODY@", files.joinpath(body).read_text(encoding="utf-8").rstrip() + "\n", 1)


def _template(form: str = "compute") -> str:
    return wrapped("separable.comp" if form == "compute" else "separable.frag", "separable.glsl")


def _f(x: float) -> str:
    """A float32 value as an exact GLSL literal."""
    v = float(np.float32(x))
    check_finite(v, "the pass plan's taps and depth parameters", PassError)
    s = repr(v)
    return s if ("." in s or "e" in s) else s + ".0"


def _array(kind: str, name: str, values: list[str]) -> str:
    body = ",\n    ".join(", ".join(values[i:i + 4]) for i in range(0, len(values), 4))
    return f"const {kind} {name}[{len(values)}] = {kind}[](\n    {body});"


def _vec(v: Sequence[float]) -> str:
    return "vec" + str(len(v)) + "(" + ", ".join(_f(x) for x in v) + ")"


def plan_constants(plan: SeparablePlan) -> str:
    """The GLSL constants of a plan's tables (every term and slot): the generated block of the shader."""
    GL_PROFILE_IDS.check(plan.slots - 1, error=PassError)
    S = plan.slots
    kmax = max(1, max((t.max_rows for t in plan.terms), default=0))
    rows_p, rows_m, sym, n_jit, n_rows, centre, sign = [], [], [], [], [], [], []
    for term in plan.terms:
        for s in range(S):
            n = int(term.n_rows[s]) if s else 0
            n_rows.append(str(n))
            n_jit.append(str(int(term.n_jit[s]) if s else 0))
            centre.append(_vec(term.centre[s]))
            sign.append(_vec(term.sign[s]))
            for k in range(kmax):
                if k < n:
                    rows_p.append(_vec(list(term.w_plus[s, k]) + [term.offsets_mm[s, k]]))
                    rows_m.append(_vec(term.w_minus[s, k]))
                    same = np.array_equal(np.float32(term.w_plus[s, k]), np.float32(term.w_minus[s, k]))
                    sym.append("true" if same else "false")
                else:
                    rows_p.append("vec4(0.0)")
                    rows_m.append("vec3(0.0)")
                    sym.append("true")
    return "\n".join([
        f"#define NSLOTS {S}",
        f"#define KMAX {kmax}",
        f"#define DEPTH_MODE {DEPTH_MODES.index(plan.depth_mode)}  // {plan.depth_mode}",
        f"#define MULTI_SLOT {int(S > 2)}",
        _array("float", "DEPTH_PARAM", [_f(plan.depth_param[s]) if s else "0.0" for s in range(S)]),
        _array("int", "N_ROWS", n_rows),
        _array("int", "N_JIT", n_jit),
        _array("vec3", "CENTRE", centre),
        _array("vec3", "SIGN", sign),
        "// per (term, slot, row): rgb = weight of the tap at +o, a = o (mm); ROW_MINUS: weight at -o",
        _array("vec4", "ROW_PLUS", rows_p),
        _array("vec3", "ROW_MINUS", rows_m),
        "// the rows whose two weights are equal (mirror pairs)",
        _array("bool", "ROW_SYMMETRIC", sym),
    ])


def _term(plan: SeparablePlan, term: int) -> int:
    """``term`` as an index of the plan's separable terms, or a PassError in the range wording."""
    return int(Quantity("term", 0, len(plan.terms) - 1, "", "the plan's separable terms", integer=True).check(
        term, "term", PassError))


def separable_source(plan: SeparablePlan, term: int, vertical: bool, layout: Layout = GPU_LAYOUT) -> str:
    """The complete GLSL source of one 1D pass (term ``term``, horizontal or vertical) of ``plan``."""
    _term(plan, term)
    lx, ly = (int(v) for v in layout.local(vertical))
    head = "\n".join([
        "// ---- generated by ssskit.backends.gl.separable_source ----",
        f"#define LOCAL_X {lx}",
        f"#define LOCAL_Y {ly}",
        f"#define SRC_BUFFER {int(layout.storage[int(bool(vertical))] == 'buffer')}",
        f"#define DST_BUFFER {int(layout.storage[1 + int(bool(vertical))] == 'buffer')}",
        f"#define VERTICAL {int(bool(vertical))}",
        f"#define TERM {int(term)}",
        plan_constants(plan),
        "// ---- end of the generated block ----",
    ])
    return _template().replace("// @GENERATED@", head, 1)


def separable_fragment_source(plan: SeparablePlan, term: int, vertical: bool) -> str:
    """The GLSL ES 3.00 fragment shader of one 1D pass (term ``term``, horizontal or vertical) of ``plan``:
    the per-pixel body of :func:`separable_source` (``separable.glsl``) in the fragment wrapper
    ``separable.frag``, for WebGL2 and OpenGL ES 3 (the live viewer runs it)."""
    _term(plan, term)
    head = "\n".join([
        "// ---- generated by ssskit.backends.gl.separable_fragment_source ----",
        f"#define VERTICAL {int(bool(vertical))}",
        f"#define TERM {int(term)}",
        plan_constants(plan),
        "// ---- end of the generated block ----",
    ])
    return _template("fragment").replace("// @GENERATED@", head, 1)


def _defaults(src: str) -> str:
    """``src`` with VERTICAL and TERM defaulting to 0 (``#ifndef``), so an engine sets them per pass."""
    for name in ("VERTICAL", "TERM"):
        src = src.replace(f"#define {name} 0\n", f"#ifndef {name}\n#define {name} 0\n#endif\n", 1)
    return src


def export_source(plan: SeparablePlan, layout: Layout = CPU_LAYOUT) -> str:
    """One GLSL 4.30 compute source for every pass of ``plan``, for an engine: the same shader the gl
    backend runs, the plan's tables baked in, with VERTICAL (0: horizontal, 1: vertical) and TERM
    (0 .. rank - 1) defaulting to 0 so each pass is the same file compiled with its defines
    (``-DVERTICAL=1 -DTERM=r``). Images are textures (``layout``'s storage; buffers are faster on NVIDIA).
    The header says what to bind and set."""
    src = _defaults(separable_source(plan, 0, False, layout))
    usage = "\n".join([
        "// ---- how to run it (ssskit.backends.gl.export_source) ----",
        f"// {len(plan.terms)} separable term(s), {plan.slots - 1} profile id(s), depth test '{plan.depth_mode}'.",
        "// Per frame and term r: the horizontal pass (VERTICAL 0, TERM r) reads the frame and writes the",
        "// intermediate image, then the vertical pass (VERTICAL 1, TERM r) reads that and writes (r = 0) or",
        "// adds to (u_accumulate = 1, r > 0) the output. Dispatch ceil(W / LOCAL_X) x ceil(H / LOCAL_Y) groups",
        "// and put a shader-image-access + texture-fetch memory barrier between passes.",
        "// Texture unit 0: the source, RGBA32F, rgb = diffuse irradiance, a = linear view depth in mm (-1 on",
        "//   pixels without SSS); unit 1 (several profile ids only): R16UI slots (0 = no SSS, s = the s-th id);",
        "//   image unit 0: the destination, rgba32f. Uniforms: u_size = (W, H); u_f = fx (horizontal) or fy",
        "//   (vertical) in pixels; u_base = the frame's hash key, lowbias32(lowbias32(seed ^ 0x9E3779B9) ^ frame)",
        "//   (jittered taps only); u_accumulate as above; u_pitch only with storage buffers.",
    ])
    return src.replace("// ---- generated by ssskit.backends.gl.separable_source ----",
                       usage + "\n// ---- generated by ssskit.backends.gl.separable_source ----", 1)


def export_fragment_source(plan: SeparablePlan) -> str:
    """One GLSL ES 3.00 fragment source for every pass of ``plan`` (WebGL2, OpenGL ES 3), the same per-pixel
    body as :func:`export_source`: VERTICAL and TERM default to 0; an engine (and the live viewer) inserts
    ``#define VERTICAL v`` and ``#define TERM r`` right after the ``#version`` line for each pass."""
    src = _defaults(separable_fragment_source(plan, 0, False))
    usage = "\n".join([
        "// ---- how to run it (ssskit.backends.gl.export_fragment_source) ----",
        f"// {len(plan.terms)} separable term(s), {plan.slots - 1} profile id(s), depth test '{plan.depth_mode}'.",
        "// Per frame and term r: draw the horizontal pass (VERTICAL 0, TERM r) from the frame into an intermediate",
        "// RGBA32F target, then the vertical pass (VERTICAL 1, TERM r) from that into the output target; for r > 0",
        "// set u_accumulate = 1 and bind the earlier terms' sum as u_dst (ping-pong targets: a pass never reads the",
        "// target it draws). Uniforms: u_size = (W, H); u_f = fx (horizontal) or fy (vertical) in pixels; u_base =",
        "// the frame's hash key, lowbias32(lowbias32(seed ^ 0x9E3779B9) ^ frame) (jittered taps only).",
    ])
    return src.replace("// ---- generated by ssskit.backends.gl.separable_fragment_source ----",
                       usage + "\n// ---- generated by ssskit.backends.gl.separable_fragment_source ----", 1)


class SeparableFrame:
    """A frame of the separable pass on the GPU: upload once, run the passes, read back when asked.

    >>> f = SeparableFrame(plan, diffuse, depth_mm, slots)      # doctest: +SKIP
    >>> f.run()                    # 2 passes per separable term, no readback  # doctest: +SKIP
    >>> out = f.read()             # (H, W, 3) float32, a new array            # doctest: +SKIP

    (Skipped under doctest: it needs a GL context, which the backend holds; ``plan`` is a
    :class:`~ssskit.backends.plan.SeparablePlan`, the frame arrays as
    :data:`~ssskit.backends.plan.SEPARABLE_FRAME` declares them. tests/backends/test_gl.py runs it.)
    """

    def __init__(self, plan: SeparablePlan, diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray,
                 layout: Layout | None = None):
        from .context import context

        self.ctx = context()
        self.plan = plan
        self.layout = layout = default_layout() if layout is None else layout
        h, w = slots.shape
        self.size = (w, h)
        self._textures = _Images(self.ctx, w, h, tuple(layout.storage))
        self.upload(diffuse, depth_mm, slots)
        self.programs = [(_program(plan, r, False, layout), _program(plan, r, True, layout))
                         for r in range(len(plan.terms))]

    def upload(self, diffuse: np.ndarray, depth_mm: np.ndarray, slots: np.ndarray) -> None:
        """New frame images (same size): E and depth in one RGBA32F texture, the slots in an R16UI one."""
        from .context import context

        context()
        h, w = slots.shape
        src = np.empty((h, w, 4), np.float32)
        src[..., :3] = diffuse
        inside = slots > 0
        src[..., 3] = np.where(inside, depth_mm, -1.0)
        t = self._textures
        t.write_src(src)
        if self.plan.slots > 2:
            t.slots.write(np.ascontiguousarray(slots, dtype=t.slot_dtype).tobytes())

    def run(self) -> None:
        """All passes of the frame (horizontal then vertical per term, the terms summed in the output)."""
        from .context import context

        context()
        for r in range(len(self.programs)):
            self.dispatch(r, False)
            self.dispatch(r, True)

    def dispatch(self, term: int, vertical: bool) -> None:
        """One 1D pass: horizontal reads the frame and writes the intermediate image, vertical reads that
        and writes (term 0) or adds to (later terms) the output image."""
        t = self._textures
        w, h = self.size
        lx, ly = self.layout.local(vertical)
        prog = self.programs[term][int(vertical)]
        src, dst = (t.tmp, t.out) if vertical else (t.src, t.tmp)
        _uniforms(prog, u_size=(w, h), u_pitch=t.pitch, u_f=self.plan.fy if vertical else self.plan.fx,
                  u_base=frame_base(self.plan.frame, self.plan.seed), u_accumulate=int(term > 0))
        t.bind(src, dst, self.plan.slots > 2)
        prog.run(-(-w // lx), -(-h // ly), 1)
        self.ctx.memory_barrier()

    def release(self) -> None:
        """Free the frame's device images (the frame cannot run after this)."""
        self._textures.release()

    def read(self) -> np.ndarray:
        """The filtered diffuse layer, (H, W, 3) float32 (a new array)."""
        from .context import context

        context()
        return self._textures.read_out()


def padded_pitch(width: int) -> int:
    """Texels per row of a storage-buffer image (the width plus its two border texels): a multiple of 8
    texels (128 bytes) whose count of 128-byte lines is odd, so rows do not all fall in the same cache
    sets (power-of-two strides)."""
    lines = -(-(width + 2) // 8)
    return 8 * (lines + 1 - lines % 2)


class _Images:
    """A frame's images (source, intermediate, output, slots), owned by its :class:`SeparableFrame` and
    reused by its later frames: RGBA32F textures or storage buffers of vec4 with padded rows; slots in
    R16UI."""

    def __init__(self, ctx: moderngl.Context, w: int, h: int, storage: tuple[str, ...]) -> None:
        import moderngl

        self.size = (w, h)
        self.pitch = padded_pitch(w)

        def texture(components: int, dtype: str) -> moderngl.Texture:
            tex = ctx.texture((w, h), components, dtype=dtype)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)  # integer textures are incomplete otherwise
            return tex

        def image(kind: str) -> moderngl.Texture | moderngl.Buffer:
            if kind == "texture":
                return texture(4, "f4")
            return ctx.buffer(self._bordered(np.zeros((h, w, 4), np.float32)).tobytes())  # border .a = -1

        self.src, self.tmp, self.out = (image(k) for k in storage)
        self.slots = texture(1, "u2")
        self.slot_dtype = np.uint16
        self._buffer = moderngl.Buffer
        # results are read through a staging buffer: a buffer the driver sees read back by the CPU may be
        # moved to host memory, where the passes writing it would run at PCIe speed
        self._staging = ctx.buffer(reserve=16 * self.pitch * (h + 2)) if storage[2] == "buffer" else None
        self.ctx = ctx

    def _bordered(self, image: np.ndarray) -> np.ndarray:
        """(H, W, 4) -> (H + 2, pitch, 4) with an invalid border (.a = -1) and padding."""
        w, h = self.size
        out = np.zeros((h + 2, self.pitch, 4), np.float32)
        out[..., 3] = -1.0
        out[1:h + 1, 1:w + 1] = image
        return out

    def _is_buffer(self, obj: object) -> TypeGuard[moderngl.Buffer]:
        return isinstance(obj, self._buffer)

    def write_src(self, src: np.ndarray) -> None:
        self.src.write((self._bordered(src) if self._is_buffer(self.src) else src).tobytes())

    def read_out(self) -> np.ndarray:
        w, h = self.size
        if self._is_buffer(self.out) and self._staging is not None:  # (a buffer output has its staging)
            self.ctx.copy_buffer(self._staging, self.out)
            out = np.frombuffer(self._staging.read(), np.float32).reshape(h + 2, self.pitch, 4)[1:h + 1, 1:w + 1]
        else:
            out = np.frombuffer(self.out.read(), np.float32).reshape(h, w, 4)
        return np.ascontiguousarray(out[..., :3])

    def bind(self, src: Any, dst: Any, slots: bool) -> None:
        if self._is_buffer(src):
            src.bind_to_storage_buffer(0)
        else:
            src.use(0)
        if slots:
            self.slots.use(1)
        if self._is_buffer(dst):
            dst.bind_to_storage_buffer(1)
        else:
            dst.bind_to_image(0, read=True, write=True)

    def release(self) -> None:
        for obj in (self.src, self.tmp, self.out, self.slots, self._staging):
            if obj is not None:
                obj.release()


def _uniforms(prog: moderngl.ComputeShader, **values: Any) -> None:
    """Set the uniforms the compiled program uses (the compiler drops unused ones)."""
    for name, value in values.items():
        if name in prog:
            prog[name] = value


def _program(plan: SeparablePlan, term: int, vertical: bool, layout: Layout) -> moderngl.ComputeShader:
    from .context import program

    return program(separable_source(plan, term, vertical, layout), "separable")

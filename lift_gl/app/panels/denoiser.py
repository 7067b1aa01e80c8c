"""F3 Denoiser: when to denoise (off, every frame, final frame), with which denoiser, the
à-trous filter's settings, and the noisy / denoised split view. The work is the Renderer's
(ViewSession.set_denoise); this panel only edits the settings and shows what ran."""
from __future__ import annotations

from imgui_bundle import imgui

from ...denoise import DENOISERS
from ...passes.atrous import AtrousSettings
from ..session import NOISY_SPLIT
from . import Panel, UiState, push_label_room, text_wrapped_colored

MODES = (("off", "off"), ("every", "every frame"), ("final", "final frame"))
LABELS = ("denoiser", "iterations", "sigma luminance", "sigma normal", "sigma depth", "divider")


class DenoiserPanel(Panel):
    title = "Denoiser"
    key = "F3"
    visible = False

    def draw(self, session, ui: UiState) -> None:
        if not self.begin(ui):
            return
        push_label_room(LABELS)
        self._draw(session)
        imgui.pop_item_width()
        self.end(ui)

    def _draw(self, session) -> None:
        r = session.renderer
        for i, (mode, label) in enumerate(MODES):
            if i:
                imgui.same_line()
            if imgui.radio_button(label, r.denoise_mode == mode):
                session.set_denoise(mode=mode)
        imgui.set_item_tooltip("final frame: denoised once the image freezes (its target reached, or paused)")
        index = DENOISERS.index(r.denoiser)
        changed, index = imgui.combo("denoiser", index, list(DENOISERS))
        if changed:
            session.set_denoise(denoiser=DENOISERS[index])
        imgui.set_item_tooltip("atrous: GLSL edge-avoiding à-trous (SVGF), on the GPU; onnx: the trained "
                               "network; oidn: Intel Open Image Denoise (pip install 'lift-gl[oidn]'); both on the CPU")
        if r.denoiser == "atrous":
            self._atrous(session)
        if r.denoise_mode == "off":
            imgui.text_disabled("showing the noisy mean")
            return
        split = session.display.view == NOISY_SPLIT
        changed, split = imgui.checkbox("noisy | denoised split", split)
        if changed:
            session.display.view = NOISY_SPLIT if split else "render"
        if split:
            _, session.display.split_position = imgui.slider_float("divider##denoise", session.display.split_position,
                                                                   0.0, 1.0, "%.2f")
        stats = r.stats
        shown = "denoised" if r.denoised_current else "noisy (the final frame is not reached yet)"
        imgui.text_wrapped(f"showing     {shown}")
        imgui.text_wrapped(f"runs        {stats.denoise_runs}, {stats.denoise_seconds:.3f} s in all")
        last = session.last_frame.pass_ms.get("denoise")
        if last is not None:
            imgui.text(f"last run    {last:.2f} ms")
        text_wrapped_colored(imgui.ImVec4(1.0, 0.7, 0.3, 1.0), "BIASED: denoised images trade noise for blur")
        imgui.set_item_tooltip("the error estimate and the convergence plot are of the noisy mean")

    def _atrous(self, session) -> None:
        s = AtrousSettings(**session.renderer.denoiser_options)
        values = dict(iterations=s.iterations, sigma_luminance=s.sigma_luminance, sigma_normal=s.sigma_normal,
                      sigma_depth=s.sigma_depth)
        changed = False
        c, values["iterations"] = imgui.slider_int("iterations", s.iterations, 1, 8)
        changed |= c
        c, values["sigma_luminance"] = imgui.slider_float("sigma luminance", s.sigma_luminance, 0.0, 16.0, "%.1f")
        changed |= c
        imgui.set_item_tooltip("edge-stopping on luminance, in standard deviations of the noise (0: off)")
        c, values["sigma_normal"] = imgui.slider_float("sigma normal", s.sigma_normal, 0.0, 256.0, "%.0f")
        changed |= c
        c, values["sigma_depth"] = imgui.slider_float("sigma depth", s.sigma_depth, 0.0, 4.0, "%.2f")
        changed |= c
        if changed:
            session.set_denoise(options=values)

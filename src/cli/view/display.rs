//! How the viewer's frames reach the window.
//!
//! - [`Display::Surface`] (any adapter that can present to the window,
//!   lavapipe under Xvfb included): the wgpu rasterizer draws into its HDR
//!   target, the display pass (`tonemap.wgsl`) tone-maps it straight into
//!   the swap-chain image and egui draws the panel and light markers on
//!   top. No read-back; screenshots render the same frame into offscreen
//!   targets as well (the scene alone, or with the panel) and read those back.
//! - [`Display::Blit`] (`--backend cpu`, no adapter, or no surface the
//!   adapter can present to): the offscreen renderer (wgpu with read-back,
//!   or the CPU ray-traced fallback), tone-mapped on the CPU and copied
//!   into the window with `softbuffer`. No egui panel there: the figures
//!   are in the window title and the controls are the keys.
//!
//! The window title carries the figures in both modes.

use crate::gpu::{Backend, GpuDevice};
use crate::render::gpu::GpuRenderer;
use crate::render::present::{offscreen_target, read_back_rgb8, ToneMapPass};
use crate::render::{tone_map, Frame, RenderParams, Renderer};
use anyhow::{anyhow, Context, Result};
use std::num::NonZeroU32;
use std::sync::Arc;
use winit::window::Window;

/// Screenshots wanted from the next frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct Capture {
    /// The scene alone (tone-mapped render).
    pub scene: bool,
    /// What the window shows, panel included.
    pub window: bool,
}

/// Screenshots taken by [`Display::draw`].
#[derive(Default)]
pub struct Captured {
    pub scene: Option<image::RgbImage>,
    pub window: Option<image::RgbImage>,
    /// The frame was drawn (false when the window could not take one, e.g. occluded).
    pub drawn: bool,
}

/// egui on the window: input state and its wgpu renderer.
struct EguiLayer {
    ctx: egui::Context,
    state: egui_winit::State,
    renderer: egui_wgpu::Renderer,
}

/// Swap-chain presentation with the egui panel.
pub struct SurfaceDisplay {
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    renderer: GpuRenderer,
    tonemap: ToneMapPass,
    egui: EguiLayer,
}

/// Offscreen renderer + CPU blit.
pub struct BlitDisplay {
    renderer: Renderer,
    surface: softbuffer::Surface<Arc<Window>, Arc<Window>>,
}

pub enum Display {
    Surface(Box<SurfaceDisplay>),
    Blit(Box<BlitDisplay>),
}

impl SurfaceDisplay {
    fn open(window: &Arc<Window>, vsync: bool) -> Result<SurfaceDisplay> {
        let desc = wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(window.clone()));
        let instance = wgpu::Instance::new(desc);
        let surface = instance.create_surface(window.clone()).context("creating a wgpu surface for the window")?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .context("no adapter can present to this window")?;
        let info = adapter.get_info();
        let limits = wgpu::Limits::default().using_resolution(adapter.limits());
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("linkgi viewer device"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .with_context(|| format!("opening {} for the window", info.name))?;
        let name = info.name.clone();
        device.on_uncaptured_error(Arc::new(move |e| eprintln!("GPU error on {name} (viewer): {e}")));
        let dev = Arc::new(GpuDevice { device, queue, info, limits });

        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| anyhow!("{} cannot present to this window", dev.info.name))?;
        // A linear 8-bit format when there is one: the display pass encodes sRGB
        // itself and egui expects a non-sRGB target.
        let caps = surface.get_capabilities(&adapter);
        if let Some(f) =
            caps.formats.iter().find(|f| matches!(f, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Rgba8Unorm))
        {
            config.format = *f;
        }
        config.present_mode = if vsync { wgpu::PresentMode::AutoVsync } else { wgpu::PresentMode::AutoNoVsync };
        surface.configure(&dev.device, &config);

        let renderer = GpuRenderer::new(dev.clone()).map_err(|e| anyhow!("{e}"))?;
        let tonemap = ToneMapPass::new(&dev, config.format).map_err(|e| anyhow!("{e}"))?;
        let ctx = egui::Context::default();
        // A compact panel: it should leave most of a small window to the scene.
        ctx.set_zoom_factor(0.85);
        let state = egui_winit::State::new(
            ctx.clone(),
            egui::ViewportId::ROOT,
            window.as_ref(),
            Some(window.scale_factor() as f32),
            None,
            Some(dev.limits.max_texture_dimension_2d as usize),
        );
        let egui_renderer = egui_wgpu::Renderer::new(&dev.device, config.format, egui_wgpu::RendererOptions::default());
        Ok(SurfaceDisplay {
            surface,
            config,
            renderer,
            tonemap,
            egui: EguiLayer { ctx, state, renderer: egui_renderer },
        })
    }

    fn draw(
        &mut self,
        window: &Window,
        frame: &Frame,
        params: &RenderParams,
        ui: &mut dyn FnMut(&egui::Context),
        capture: Capture,
    ) -> Result<Captured> {
        let dev = self.renderer.dev.clone();
        let size = window.inner_size();
        if (size.width, size.height) != (self.config.width, self.config.height) {
            self.config.width = size.width.max(1);
            self.config.height = size.height.max(1);
            self.surface.configure(&dev.device, &self.config);
        }
        let texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(Captured::default())
            }
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&dev.device, &self.config);
                return Ok(Captured::default());
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(anyhow!("acquiring the window's next image failed validation"))
            }
        };
        let (w, h) = (texture.texture.width(), texture.texture.height());
        let params = RenderParams { width: w, height: h, ..*params };

        // The panel.
        let egui = &mut self.egui;
        let raw = egui.state.take_egui_input(window);
        let mut out = egui.ctx.run_pass(raw, |ctx| ui(ctx));
        // Taken now so that an error below cannot drop unapplied deltas.
        let set: Vec<_> = out.textures_delta.set.drain().collect();
        let free: Vec<_> = out.textures_delta.free.drain().collect();
        egui.state.handle_platform_output(window, out.platform_output);
        let ppp = out.pixels_per_point;
        let prims = egui.ctx.tessellate(out.shapes, ppp);
        let screen = egui_wgpu::ScreenDescriptor { size_in_pixels: [w, h], pixels_per_point: ppp };
        for (id, deltas) in &set {
            for delta in deltas {
                egui.renderer.update_texture(&dev.device, &dev.queue, *id, delta);
            }
        }
        let mut enc =
            dev.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("egui buffers") });
        let mut cmds = egui.renderer.update_buffers(&dev.device, &dev.queue, &mut enc, &prims, &screen);
        cmds.push(enc.finish());
        dev.queue.submit(cmds);

        // Targets: the window, then the screenshots asked for.
        let view = texture
            .texture
            .create_view(&wgpu::TextureViewDescriptor { label: Some("window image view"), ..Default::default() });
        let shots: Vec<(bool, wgpu::Texture)> = [(capture.scene, false), (capture.window, true)]
            .into_iter()
            .filter(|(want, _)| *want)
            .map(|(_, with_panel)| (with_panel, offscreen_target(&dev, w, h, self.tonemap.format())))
            .collect();
        let shot_views: Vec<wgpu::TextureView> =
            shots.iter().map(|(_, t)| t.create_view(&Default::default())).collect();
        let mut targets = vec![&view];
        targets.extend(shot_views.iter());
        let mut panel_on = vec![true];
        panel_on.extend(shots.iter().map(|(p, _)| *p));
        let renderer = &egui.renderer;
        self.renderer
            .present(frame, &params, &self.tonemap, &targets, |enc, i, target| {
                if panel_on[i] {
                    let mut pass = enc
                        .begin_render_pass(&wgpu::RenderPassDescriptor {
                            label: Some("egui panel pass"),
                            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                                view: target,
                                depth_slice: None,
                                resolve_target: None,
                                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                            })],
                            depth_stencil_attachment: None,
                            timestamp_writes: None,
                            occlusion_query_set: None,
                            multiview_mask: None,
                        })
                        .forget_lifetime();
                    renderer.render(&mut pass, &prims, &screen);
                }
                Ok(())
            })
            .map_err(|e| anyhow!("{e}"))?;
        window.pre_present_notify();
        dev.queue.present(texture);
        for id in &free {
            egui.renderer.free_texture(id);
        }
        let mut got = Captured { drawn: true, ..Default::default() };
        for (with_panel, tex) in &shots {
            let img = read_back_rgb8(&dev, tex).map_err(|e| anyhow!("{e}"))?;
            if *with_panel {
                got.window = Some(img);
            } else {
                got.scene = Some(img);
            }
        }
        Ok(got)
    }
}

impl Display {
    /// Swap chain with the panel unless `backend` is `cpu` or `blit` is
    /// asked for; the blit path (with one line saying why) when that cannot be set up.
    pub fn open(window: &Arc<Window>, backend: Backend, vsync: bool, blit: bool) -> Result<Display> {
        if backend != Backend::Cpu && !blit {
            match SurfaceDisplay::open(window, vsync) {
                Ok(d) => return Ok(Display::Surface(Box::new(d))),
                Err(e) => {
                    eprintln!("note: {e:#}; drawing through an offscreen renderer, no panel (figures in the title)")
                }
            }
        }
        let renderer = Renderer::open(backend);
        let context =
            softbuffer::Context::new(window.clone()).map_err(|e| anyhow!("window presentation (softbuffer): {e}"))?;
        let surface = softbuffer::Surface::new(&context, window.clone())
            .map_err(|e| anyhow!("window surface (softbuffer): {e}"))?;
        Ok(Display::Blit(Box::new(BlitDisplay { renderer, surface })))
    }

    pub fn describe(&self) -> String {
        match self {
            Display::Surface(s) => s.renderer.dev.info.name.clone(),
            Display::Blit(b) => format!("{} (offscreen + blit)", b.renderer.describe()),
        }
    }

    /// Feeds a window event to the panel; true when the panel used it.
    pub fn on_event(&mut self, window: &Window, event: &winit::event::WindowEvent) -> bool {
        match self {
            Display::Surface(s) => s.egui.state.on_window_event(window, event).consumed,
            Display::Blit(_) => false,
        }
    }

    /// The pointer is over the panel or dragging one of its widgets.
    pub fn wants_pointer(&self) -> bool {
        match self {
            Display::Surface(s) => s.egui.ctx.egui_wants_pointer_input() || s.egui.ctx.egui_is_using_pointer(),
            Display::Blit(_) => false,
        }
    }

    /// Window pixels per egui point (1 in blit mode).
    pub fn pixels_per_point(&self) -> f32 {
        match self {
            Display::Surface(s) => s.egui.ctx.pixels_per_point(),
            Display::Blit(_) => 1.0,
        }
    }

    /// Renders `frame` offscreen at `params`' size (linear radiance), on the
    /// renderer that draws the window: the automatic exposure's probe.
    pub fn probe(&mut self, frame: &Frame, params: &RenderParams) -> Result<crate::render::HdrImage> {
        Ok(match self {
            Display::Surface(s) => s.renderer.render(frame, params)?.0,
            Display::Blit(b) => b.renderer.render(frame, params)?.0,
        })
    }

    /// Draws one frame; `ui` builds the panel (swap-chain mode only).
    pub fn draw(
        &mut self,
        window: &Window,
        frame: &Frame,
        params: &RenderParams,
        ui: &mut dyn FnMut(&egui::Context),
        capture: Capture,
    ) -> Result<Captured> {
        match self {
            Display::Surface(s) => s.draw(window, frame, params, ui, capture),
            Display::Blit(b) => {
                let (hdr, _) = b.renderer.render(frame, params)?;
                let img = tone_map(&hdr, params.exposure);
                let (Some(w), Some(h)) = (NonZeroU32::new(img.width()), NonZeroU32::new(img.height())) else {
                    return Ok(Captured::default());
                };
                b.surface.resize(w, h).map_err(|e| anyhow!("resizing the window buffer: {e}"))?;
                let mut buf = b.surface.buffer_mut().map_err(|e| anyhow!("window buffer: {e}"))?;
                for (dst, p) in buf.iter_mut().zip(img.pixels()) {
                    *dst = (p[0] as u32) << 16 | (p[1] as u32) << 8 | p[2] as u32;
                }
                buf.present().map_err(|e| anyhow!("presenting: {e}"))?;
                Ok(Captured {
                    scene: capture.scene.then(|| img.clone()),
                    window: capture.window.then(|| img.clone()),
                    drawn: true,
                })
            }
        }
    }
}

// The viewer's Gaussian view; see gaussian_view.h.
#include "gaussian_view.h"

#include "splat/mesh_gaussians.h"
#include "world/mesh_voxelize.h"

#include <algorithm>
#include <chrono>
#include <filesystem>

namespace icube::viewer {

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

bool GaussianView::Key::operator==(const Key& k) const {
  return cam.c2w == k.cam.c2w && cam.K.fx == k.cam.K.fx && cam.K.fy == k.cam.K.fy && cam.K.cx == k.cam.K.cx &&
         cam.K.cy == k.cam.K.cy && cam.K.width == k.cam.K.width && cam.K.height == k.cam.K.height &&
         frame == k.frame && detail == k.detail && own_car == k.own_car;
}

GaussianView::GaussianView(gpu::Context& ctx, const std::string& scene_json, const std::string& sky_png,
                           const GaussianViewOptions& o)
    : ctx_(ctx), opt_(o), source_(scene_json), renderer_(ctx), to_rgba8_(ctx) {
  const auto t0 = Clock::now();
  splat::SplatScene sc = splat::read_splat_scene(scene_json);
  frames_ = sc.frames();
  const uint32_t degree = splat::max_sh_degree(sc);
  stats_.static_gaussians = sc.static_set.size();
  stats_.objects = sc.objects.size();
  {
    const splat::ChunkedGaussians chunks = splat::build_gaussian_chunks(sc.static_set, opt_.chunking);
    sc.static_set = splat::GaussianCloud{};  // the chunked copy is all that is needed, and only until uploaded
    stats_.coarse_gaussians = chunks.coarse.size();
    stats_.chunks = chunks.chunks.size();
    lod_ = std::make_unique<splat::LodGaussiansGpu>(ctx, chunks, degree);
  }
  objects_ = std::move(sc.objects);
  stats_.resident_bytes = lod_->resident_bytes();
  splat_opts_.depth = false;
  splat_opts_.sky = sky_png.empty()
                        ? splat::sky_gradient()
                        : splat::sky_equirect(std::make_shared<const splat::SkyImage>(splat::read_sky_png(sky_png)));
  stats_.load_s = ms_since(t0) / 1000.0;
}

size_t GaussianView::frame_of(size_t time_index) const {
  return frames_ == 0 ? 0 : std::min(time_index, frames_ - 1);
}

void GaussianView::set_own_car(const world::TriangleMesh& mesh, double length, double width, double height) {
  // 8 cm discs: ~3.5 pixels wide from a chase camera 8 m behind at 960 pixels across, so the
  // surface stays closed, at under half the Gaussians of the 5 cm default (re-placed every frame
  // the car moves).
  splat::MeshGaussianOptions o;
  o.spacing = 0.08;
  own_car_ = splat::mesh_surface_gaussians(world::fit_mesh_to_box(mesh, length, width, height), {}, o);
  placed_.reset();
  last_.reset();
}

void GaussianView::place_objects(size_t frame, const std::optional<glm::dmat4>& own_car) {
  if (placed_ && placed_->first == frame && placed_->second == own_car) return;
  // The scene's objects are composed once per frame; a moving own car only re-places itself.
  if (!composed_frame_ || *composed_frame_ != frame) {
    composed_ = splat::compose_objects(objects_, frame, lod_->sh_degree());
    composed_frame_ = frame;
  }
  if (own_car && own_car_.size() > 0) {
    splat::GaussianCloud extra = composed_;
    splat::append_placed(extra, own_car_, *own_car);
    lod_->set_extra(extra);
  } else {
    lod_->set_extra(composed_);
  }
  placed_ = std::make_pair(frame, own_car);
}

bool GaussianView::draw(const render::Camera& cam, size_t time_index, GaussianDetail detail,
                        const glm::dmat4* own_car) {
  Key key{cam, frame_of(time_index), detail, own_car ? std::optional<glm::dmat4>(*own_car) : std::nullopt};
  if (last_ && *last_ == key) {
    ++stats_.reused;
    return false;
  }
  place_objects(key.frame, key.own_car);
  splat::LodOptions whole;
  whole.frustum = false;
  const splat::LodOptions& lo =
      detail == GaussianDetail::Whole ? whole : detail == GaussianDetail::Still ? opt_.still : opt_.moving;
  const splat::LodPicks picks = splat::pick_chunks(lod_->chunks(), cam, lo);
  splat::LodAssembleStats as;
  const splat::GpuGaussians& g = lod_->assemble(picks.picks, &as);
  const auto t0 = Clock::now();
  splat::SplatOptions so = splat_opts_;
  so.depth_key_bits = detail == GaussianDetail::Moving ? opt_.moving_key_bits : 32;
  renderer_.render(g, cam, so, &stats_.timings, nullptr, /*download=*/false);
  stats_.render_ms = ms_since(t0);
  stats_.assemble_ms = as.ms;
  stats_.drawn = g.count;
  stats_.chunks_fine = picks.chunks_fine;
  stats_.chunks_coarse = picks.chunks_coarse;
  stats_.chunks_out = picks.chunks_out;
  stats_.detail = detail;
  ++stats_.renders;
  width_ = cam.K.width;
  height_ = cam.K.height;
  gpu::ensure_capacity(ctx_, rgba8_, uint64_t{width_} * height_ * 4, "gaussian-view-rgba8");
  last_ = key;
  converted_ = false;
  return true;
}

void GaussianView::record_present(gpu::CommandList& cmd) {
  if (converted_) return;
  to_rgba8_.record(cmd, renderer_.buffers().rgba, rgba8_, uint64_t{width_} * height_);
  converted_ = true;
}

std::vector<uint8_t> GaussianView::download_rgba() {
  if (!last_) return {};
  if (!converted_) ctx_.submit_and_wait([&](gpu::CommandList& cmd) { record_present(cmd); });
  return gpu::download_vector<uint8_t>(ctx_, rgba8_, size_t{width_} * height_ * 4);
}

}  // namespace icube::viewer

// papertear-viewer [SCENARIO] [--set KEY=VALUE]... [--frames N --screenshot FILE.png] [--threads N] [--realtime]
//   (docs/viewer.md, issue 7)
//
// Mouse: left click on the sheet puts a finger there (a vertex is inserted at the picked pattern point)
// and dragging moves it in the view plane (Shift: in depth); left drag on a finger grabs it (and every
// selected finger with it); Ctrl+click toggles a finger in the selection; right click on a finger lets
// go; left drag elsewhere orbits, right/middle drag elsewhere pans, wheel zooms.
// Keys: Space play/pause, N step, R reset, G select every finger on the sheet (a hand), Q/E rotate the
// selected fingers about their centroid around the view axis, Esc clear the selection, W wireframe,
// Ctrl+S record the session to a scenario file, F frame the sheet. Another scenario loads from the
// panel's Scenario section or by dropping its file on the window.
// The simulation follows the wall clock (SimulationClock) and its steps run on a worker thread
// (BackgroundStepper) while frames are drawn. A frame that finds no step running owns the simulation: it
// copies what the panel, the markers and the input read (SheetView), applies the queued edits, uploads the
// vertex data, starts the steps that are due and draws. A frame that finds a step still running draws the
// last uploaded state with the current camera and panel, so frames are not held up by a step that takes
// longer than a frame; finger moves made meanwhile are queued, and rare edits (a new finger, release,
// reset, record) wait for the step (sync).
#define GL_GLEXT_PROTOTYPES 1
#include <GL/gl.h>
#include <GL/glext.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>

#include "apps/viewer/recorder.hpp"
#include "apps/viewer/simulation_clock.hpp"
#include "apps/viewer/renderer.hpp"
#include "apps/viewer/sheet_view.hpp"
#include "engine/picking.hpp"
#include "engine/scenario.hpp"
#include "engine/simulation.hpp"

#include <oneapi/tbb/info.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace pt;
using namespace pt::viewer;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kExitOk = 0, kExitInternal = 1, kExitInput = 2;
constexpr double kPi = 3.14159265358979323846;
constexpr std::array<float, 4> kBackground = {0.20f, 0.22f, 0.26f, 1.0f};  // the scene's clear colour

// The built-in scenario: an A4 sheet with a small notch in the middle of its top edge, no fingers.
const char* kDefaultScenario = R"({
  "name": "viewer-default",
  "description": "A4 sheet with a 1 cm notch in its top edge; put fingers on it with the mouse.",
  "sheet": { "outline": [[0,0],[0.21,0],[0.21,0.297],[0.109,0.297],[0.105,0.287],[0.101,0.297],[0,0.297]],
             "triangles": 1000 },
  "sim": { "fps": 30, "substeps": 10, "frames": 300, "gravity": [0, 0, -9.81] },
  "fingers": [{ "name": "placeholder", "at": [0.105, 0.1] }]
})";

struct Options {
  std::string scenario;
  std::vector<std::string> settings;  // --set KEY=VALUE, written into the scenario's JSON (papertear --set)
  int frames = -1;
  std::string screenshot;
  // Simulation threads. One: the simulation steps on one core while the frame is drawn on the other
  // (llvmpipe rasterises on the CPU); with two, the step's threads and llvmpipe's fight over both cores
  // and fewer frames are drawn.
  int threads = 1;
  int width = 1280, height = 800;
  int samples = 0;  // MSAA samples (llvmpipe: 4× costs several times the fill time)
  bool demo_drag = false;  // headless: click two points of the sheet and pull them apart with the mouse code
  std::string record;      // headless: record the session to this file at the end
  // Headless runs step the simulation once per rendered frame (lockstep: reproducible, what the tests use);
  // --realtime makes them tick like an interactive session, for measuring it under xvfb.
  bool realtime = false;
};

// --help only (on stdout): a bad command line gets its one line on stderr, without the usage after it.
void usage() {
  std::printf("usage: papertear-viewer [SCENARIO] [--set KEY=VALUE]... [--frames N] [--screenshot FILE.png] "
              "[--threads N] [--size WxH] [--msaa N] [--realtime]\n");
}

bool parse_args(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* what) -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "papertear-viewer: %s needs a value\n", what);
        return nullptr;
      }
      return argv[++i];
    };
    auto number = [&](const char* s, int lo, int hi, int& out) {
      char* end = nullptr;
      const long v = std::strtol(s, &end, 10);
      if (!s[0] || *end || v < lo || v > hi) {
        std::fprintf(stderr, "papertear-viewer: %s: expected an integer in [%d, %d], got \"%s\"\n", a.c_str(), lo, hi, s);
        return false;
      }
      out = static_cast<int>(v);
      return true;
    };
    if (a == "--frames") {
      const char* v = value("--frames");
      if (!v || !number(v, 0, 1000000, o.frames)) return false;
    } else if (a == "--screenshot") {
      const char* v = value("--screenshot");
      if (!v) return false;
      o.screenshot = v;
    } else if (a == "--threads") {
      const char* v = value("--threads");
      if (!v || !number(v, 1, 256, o.threads)) return false;
    } else if (a == "--set") {
      const char* v = value("--set");
      if (!v) return false;
      o.settings.push_back(v);
    } else if (a == "--realtime") {
      o.realtime = true;
    } else if (a == "--demo-drag") {
      o.demo_drag = true;
    } else if (a == "--record") {
      const char* v = value("--record");
      if (!v) return false;
      o.record = v;
    } else if (a == "--msaa") {
      const char* v = value("--msaa");
      if (!v || !number(v, 0, 16, o.samples)) return false;
    } else if (a == "--size") {
      const char* v = value("--size");
      if (!v || std::sscanf(v, "%dx%d", &o.width, &o.height) != 2 || o.width < 64 || o.height < 64 ||
          o.width > 8192 || o.height > 8192) {
        std::fprintf(stderr, "papertear-viewer: --size: expected WxH\n");
        return false;
      }
    } else if (a == "-h" || a == "--help") {
      usage();
      std::exit(kExitOk);
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "papertear-viewer: unknown option %s (--help for the usage)\n", a.c_str());
      return false;
    } else if (o.scenario.empty()) {
      o.scenario = a;
    } else {
      std::fprintf(stderr, "papertear-viewer: more than one scenario (%s)\n", a.c_str());
      return false;
    }
  }
  if (!o.screenshot.empty() && o.frames < 0) o.frames = 60;
  return true;
}

Scenario load_initial(const std::string& path, const std::vector<std::string>& settings) {
  if (!path.empty()) return load_scenario(path, settings);
  for (const fs::path& p : {fs::path("scenarios/demo.json"), fs::path(PT_SOURCE_DIR) / "scenarios/demo.json"})
    if (fs::exists(p)) return load_scenario(p.string(), settings);
  if (!settings.empty()) throw InputError("--set " + settings.front() + ": needs a scenario file (none found)");
  // Scenario files need a finger; the built-in sheet starts with none (the user puts them on).
  Scenario s = parse_scenario(kDefaultScenario, "<built-in default>");
  s.fingers.clear();
  return s;
}

// A ring buffer of the last samples of one timing series, for ImGui::PlotLines.
struct Series {
  std::array<float, 240> v{};
  int head = 0, count = 0;
  void add(double x) {
    v[head] = static_cast<float>(x);
    head = (head + 1) % static_cast<int>(v.size());
    count = std::min(count + 1, static_cast<int>(v.size()));
  }
  float max() const { return count ? *std::max_element(v.begin(), v.end()) : 0.f; }
  float avg() const {
    float s = 0;
    for (float x : v) s += x;
    return count ? s / count : 0.f;
  }
};

struct Drag {
  enum Mode { None, Finger, Orbit, Pan } mode = None;
  double x0 = 0, y0 = 0, last_x = 0, last_y = 0;
  int finger = -1;
  Vec3 plane_point = Vec3::Zero();            // the grabbed finger's target at the press
  std::vector<std::pair<int, Vec3>> start;    // moved fingers and their targets at the press
  bool moved = false;
};

// One finished simulation step's timings, handed from the stepper to the frame that collects it.
struct StepTiming {
  float step_ms = 0;
  std::array<float, 5> groups{};  // physics, geometry, tearing, carving, frame (FrameProfile, ms)
};

struct App {
  Options opt;
  GLFWwindow* window = nullptr;
  Scenario scenario;        // what Reset rebuilds from (parameters applied on reset are written here)
  std::unique_ptr<Simulation> sim;
  Picker picker;
  Renderer renderer;
  Camera camera;
  Drag drag;
  std::set<int> selected;
  bool playing = true, step_once = false, wireframe = false, show_pattern = true;
  int finger_counter = 0;
  std::array<Series, 5> series;  // physics, geometry, tearing, carving, frame
  Series sim_ms, render_ms, sheet_ms, ui_ms, prepare_ms;
  viewer::SimulationClock sim_clock;
  viewer::BackgroundStepper stepper;  // steps the simulation while frames are drawn
  bool own = true;              // this frame owns the simulation (no step running)
  double unclocked = 0;         // wall seconds since the clock last ran (it runs in frames that own)
  SheetView view;               // the simulation as of the last frame that owned it
  QueuedEdits edits;            // made since, written before the next step (the panel's live material too)
  std::vector<StepTiming> finished_steps;  // written by the stepper's job, collected when it is done
  int64_t frames_owning = 0;    // frames that read the simulation (the rest drew the last uploaded state)
  // Headless without --realtime: one simulation frame per drawn frame.
  bool lockstep() const { return opt.frames >= 0 && !opt.realtime; }
  // The ImGui windows (panel, tooltips) drawn into a layer at most every kPanelPeriod s, or every frame
  // while the user works in them; composited over the scene every frame (see draw_ui).
  Layer ui_layer;  // the windows over transparent black (premultiplied)
  Layer ui_flat;   // the same over the background colour: an exact copy where nothing else is behind
  int inset_rect[4] = {0, 0, 0, 0};  // the pattern inset, GL pixels: x, y, w, h
  double ui_drawn_at = -1e9;
  int ui_rect[4] = {0, 0, 0, 0};  // composited rectangle, GL pixels: x, y, w, h
  bool ui_refresh = true;         // draw the windows again this frame (set by whoever changes them)
  double last_pick_us = 0, max_pick_us = 0;
  int picks = 0;
  char record_path[512] = {0};
  char load_path[512] = {0};
  std::string dropped_path;  // a file dropped on the window, loaded by the next frame
  std::string status;
  double status_until = 0;
  bool pending_reset_params = false;
  // The thickness takes effect on Reset: it sets the masses and the stiffness of the factorised system,
  // which the engine builds with the sheet. The other parameters are live (edits).
  double thickness = 1e-4;
  // The tear rule (tearing.direction), applied on Reset: index into kDirections.
  static constexpr const char* kDirections[3] = {"tension_rays", "fan", "material_force"};
  int direction = 0;

  void say(const std::string& s) {
    status = s;
    status_until = glfwGetTime() + 6.0;
    std::fprintf(stderr, "papertear-viewer: %s\n", s.c_str());
  }

  void reset() {
    sync();
    // The sheet starts again with the panel's values, the live ones included.
    scenario.material.thickness = thickness;
    scenario.tearing.direction = kDirections[direction];
    write_live_parameters(edits, scenario);
    EngineOptions eo;
    eo.threads = opt.threads;
    sim = std::make_unique<Simulation>(scenario, eo);
    renderer.load_sheet(*sim);
    picker.update(sim->sheet());
    edits = live_parameters_of(scenario);  // the same values, nothing queued
    finished_steps.clear();
    capture_view();
    selected.clear();
    drag = Drag{};
    finger_counter = 0;
    pending_reset_params = false;
    ui_refresh = true;
    for (Series& s : series) s = Series{};
  }

  void take_parameters_from_scenario() {
    thickness = scenario.material.thickness;
    direction = 0;
    for (int k = 0; k < 3; ++k)
      if (scenario.tearing.direction == kDirections[k]) direction = k;
    if (scenario.tearing.direction == "bisector") direction = 1;  // the fan rule's other name
    edits = live_parameters_of(scenario);
    std::string base = scenario.name.empty() ? "session" : scenario.name;
    std::snprintf(record_path, sizeof record_path, "%s-session.json", base.c_str());
  }

  // --- simulation ---------------------------------------------------------------------------------------

  // Runs on the stepper: `steps` simulation frames, their timings kept for collect_steps(), then the
  // picker brought up to date (a refit, or a rebuild after a cut: ~0.2 ms at 1 000 triangles, which a
  // click would otherwise pay; BM_PickAfterCut), so a pick is only the ray cast.
  void advance(int steps) {
    for (int k = 0; k < steps; ++k) {
      const auto t0 = Clock::now();
      sim->step();
      StepTiming st;
      st.step_ms = static_cast<float>(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      const FrameProfile& p = sim->last_profile();
      st.groups = {float(p.physics()), float(p.geometry()), float(p.tearing()), float(p.carving), float(p.frame)};
      finished_steps.push_back(st);
    }
    picker.update(sim->sheet());
  }

  // The steps' timings into the panel's series (only while no step runs: finished_steps is the job's).
  void collect_steps() {
    for (const StepTiming& st : finished_steps) {
      sim_ms.add(st.step_ms);
      for (int g = 0; g < 5; ++g) series[g].add(st.groups[g]);
    }
    finished_steps.clear();
  }

  // Waits for the running step, if any: from here on this frame owns the simulation.
  void sync() {
    stepper.wait();
    if (!own) {
      own = true;
      collect_steps();
    }
  }

  void capture_view() { capture_sheet_view(*sim, edits, view); }

  // --- fingers ------------------------------------------------------------------------------------------

  // The position a finger is heading to: its last key (set by move_finger, or queued), else its target.
  Vec3 finger_goal(int i) const { return view.fingers[i].goal; }
  Vec3 finger_position(int i) const { return view.fingers[i].position; }
  bool finger_active(int i) const { return view.fingers[i].active; }

  // The active finger drawn nearest to window pixel (x, y), within `radius` pixels, or −1.
  int finger_at(double x, double y, double radius = 14) const {
    int best = -1;
    double best_d = radius * radius;
    for (int i = 0; i < static_cast<int>(view.fingers.size()); ++i) {
      if (!finger_active(i)) continue;
      double px, py;
      if (!camera.project(finger_position(i), px, py)) continue;
      const double d = (px - x) * (px - x) + (py - y) * (py - y);
      if (d < best_d) {
        best_d = d;
        best = i;
      }
    }
    return best;
  }

  // Queued: a frame drawn while a step runs must not touch the simulation (apply_queued_edits writes it).
  void move(int i, const Vec3& target) {
    if (!finger_active(i) || !target.allFinite()) return;
    queue_finger_move(i, target, edits);
    view.fingers[i].goal = target;
  }

  std::optional<PickHit> pick_at(double x, double y) {
    Vec3 o, d;
    camera.ray(x, y, o, d);
    const auto t0 = Clock::now();
    auto hit = picker.pick(o, d);  // the picker is up to date: advance() and every edit update it
    last_pick_us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
    max_pick_us = std::max(max_pick_us, last_pick_us);
    ++picks;
    return hit;
  }

  void press_left(double x, double y, int mods) {
    drag = Drag{};
    drag.x0 = drag.last_x = x;
    drag.y0 = drag.last_y = y;
    const int f = finger_at(x, y);
    if (mods & GLFW_MOD_CONTROL) {
      if (f >= 0) {
        if (!selected.erase(f)) selected.insert(f);
      }
      return;
    }
    int grab = f;
    if (grab < 0) {
      sync();  // picks the sheet as it is now, and a new finger is an edit of the simulation
      if (auto hit = pick_at(x, y)) {
        std::string name = std::to_string(++finger_counter);
        name.insert(name.begin(), 'F');  // not "F" + ...: GCC 12 warns falsely (-Wrestrict) there
        grab = sim->attach_finger(name, hit->uv);
        if (grab < 0) say("no sheet under the cursor at " + name);
        else picker.update(sim->sheet());
        capture_view();
      }
    }
    if (grab >= 0) {
      if (!selected.count(grab)) {
        selected.clear();
        selected.insert(grab);
      }
      drag.mode = Drag::Finger;
      drag.finger = grab;
      drag.plane_point = finger_goal(grab);
      for (int s : selected)
        if (finger_active(s)) drag.start.push_back({s, finger_goal(s)});
      return;
    }
    drag.mode = Drag::Orbit;
  }

  void drag_to(double x, double y, int mods) {
    const double dx = x - drag.last_x, dy = y - drag.last_y;
    drag.last_x = x;
    drag.last_y = y;
    if (dx == 0 && dy == 0) return;
    drag.moved = true;
    switch (drag.mode) {
      case Drag::Orbit: camera.orbit(dx, dy); break;
      case Drag::Pan: camera.pan(dx, dy); break;
      case Drag::Finger: {
        const Vec3 n = camera.forward();
        Vec3 delta;
        if (mods & GLFW_MOD_SHIFT) {
          // Depth: vertical motion moves along the view axis (up = away from the viewer).
          const double scale = 2.0 * camera.distance * std::tan(camera.fov_deg * kPi / 360.0) / camera.height;
          drag.plane_point += n * (-dy * scale);
          drag.x0 = x;
          drag.y0 = y;
          delta = drag.plane_point - drag.start.front().second;
          for (auto& [i, p0] : drag.start)
            if (i == drag.finger) delta = drag.plane_point - p0;
        } else {
          // The view plane through the grabbed point: the cursor ray's intersection.
          Vec3 o, d;
          camera.ray(x, y, o, d);
          const double denom = d.dot(n);
          if (std::abs(denom) < 1e-9) return;
          const double t = (drag.plane_point - o).dot(n) / denom;
          const Vec3 p = o + t * d;
          Vec3 p0 = drag.plane_point;
          for (auto& [i, q] : drag.start)
            if (i == drag.finger) p0 = q;
          delta = p - p0;
          // Keep the depth offset accumulated with Shift.
          delta += n * (drag.plane_point - p0).dot(n);
        }
        for (auto& [i, p0] : drag.start) move(i, p0 + delta);
        break;
      }
      default: break;
    }
  }

  void release_at(double x, double y) {
    const int f = finger_at(x, y);
    if (f >= 0) {
      sync();
      sim->release_finger(f);
      capture_view();
      selected.erase(f);
      say("released " + view.fingers[f].name);
    }
  }

  // Q/E: the selected fingers turn rigidly about their centroid around the view axis.
  void rotate_selection(double radians) {
    std::vector<int> ids;
    for (int i : selected)
      if (finger_active(i)) ids.push_back(i);
    if (ids.empty()) return;
    Vec3 c = Vec3::Zero();
    for (int i : ids) c += finger_goal(i);
    c /= static_cast<double>(ids.size());
    const Eigen::AngleAxisd r(radians, camera.forward());
    for (int i : ids) move(i, c + r * (finger_goal(i) - c));
  }

  // Another scenario replaces the session (its parameters taken as the panel's); a file that does not
  // load leaves the session as it was and says why in the panel.
  void load(const std::string& path) {
    Scenario loaded;
    try {
      loaded = load_scenario(path);
    } catch (const std::exception& e) {
      say(std::string("not loaded: ") + e.what());
      return;
    }
    scenario = std::move(loaded);  // the step running, if any, reads its own copy (reset waits for it)
    take_parameters_from_scenario();
    reset();
    camera.frame_sheet(sim->sheet(), scenario.sim.gravity);
    glfwSetWindowTitle(window, ("papertear-viewer — " + scenario.name).c_str());
    std::snprintf(load_path, sizeof load_path, "%s", path.c_str());
    say("loaded " + path);
  }

  void record() { record_to(record_path); }
  void record_to(const std::string& path) {
    sync();
    apply_queued_edits(edits, *sim);
    if (sim->sheet().fingers.empty()) {
      say("nothing to record: put a finger on the sheet first (a scenario needs one)");
      return;
    }
    try {
      write_session(*sim, path);
      say(std::string("recorded ") + std::to_string(sim->frame()) + " frames to " + path);
    } catch (const std::exception& e) {
      say(std::string("record failed: ") + e.what());
    }
  }

  // --- input --------------------------------------------------------------------------------------------

  void handle_input(double dt) {
    ImGuiIO& io = ImGui::GetIO();
    double x, y;
    glfwGetCursorPos(window, &x, &y);
    int mods = 0;
    if (glfwGetKey(window, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS || glfwGetKey(window, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS)
      mods |= GLFW_MOD_SHIFT;
    if (glfwGetKey(window, GLFW_KEY_LEFT_CONTROL) == GLFW_PRESS ||
        glfwGetKey(window, GLFW_KEY_RIGHT_CONTROL) == GLFW_PRESS)
      mods |= GLFW_MOD_CONTROL;

    if (!io.WantCaptureMouse) {
      if (ImGui::IsMouseClicked(ImGuiMouseButton_Left)) press_left(x, y, mods);
      if (ImGui::IsMouseClicked(ImGuiMouseButton_Right)) {
        drag = Drag{};
        drag.mode = Drag::Pan;
        drag.x0 = drag.last_x = x;
        drag.y0 = drag.last_y = y;
      }
      if (ImGui::IsMouseClicked(ImGuiMouseButton_Middle)) {
        drag = Drag{};
        drag.mode = Drag::Pan;
        drag.last_x = x;
        drag.last_y = y;
      }
      if (io.MouseWheel != 0) camera.zoom(std::pow(0.9, io.MouseWheel));
    }
    if (drag.mode != Drag::None) {
      const bool down = ImGui::IsMouseDown(ImGuiMouseButton_Left) || ImGui::IsMouseDown(ImGuiMouseButton_Right) ||
                        ImGui::IsMouseDown(ImGuiMouseButton_Middle);
      if (down) drag_to(x, y, mods);
      if (ImGui::IsMouseReleased(ImGuiMouseButton_Right) && !drag.moved && !io.WantCaptureMouse) release_at(x, y);
      if (!down) drag = Drag{};
    }

    if (io.WantCaptureKeyboard) return;
    if (ImGui::IsKeyPressed(GLFW_KEY_SPACE)) playing = !playing;
    if (ImGui::IsKeyPressed(GLFW_KEY_N)) step_once = true;
    if (ImGui::IsKeyPressed(GLFW_KEY_R, false)) reset();
    if (ImGui::IsKeyPressed(GLFW_KEY_W, false)) wireframe = !wireframe;
    if (ImGui::IsKeyPressed(GLFW_KEY_F, false)) {
      sync();
      camera.frame_sheet(sim->sheet(), scenario.sim.gravity);
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_ESCAPE, false)) selected.clear();
    if (ImGui::IsKeyPressed(GLFW_KEY_G, false)) {
      selected.clear();
      for (int i = 0; i < static_cast<int>(view.fingers.size()); ++i)
        if (finger_active(i)) selected.insert(i);
    }
    if ((mods & GLFW_MOD_CONTROL) && ImGui::IsKeyPressed(GLFW_KEY_S, false)) record();
    const double rate = kPi / 2;  // 90°/s
    if (ImGui::IsKeyDown(GLFW_KEY_Q)) rotate_selection(rate * dt);
    if (ImGui::IsKeyDown(GLFW_KEY_E)) rotate_selection(-rate * dt);
  }

  // --- overlays and panels ------------------------------------------------------------------------------

  void draw_finger_markers() {
    ImDrawList* dl = ImGui::GetBackgroundDrawList();
    for (int i = 0; i < static_cast<int>(view.fingers.size()); ++i) {
      if (!finger_active(i)) continue;
      double px, py;
      if (!camera.project(finger_position(i), px, py)) continue;
      const bool sel = selected.count(i) > 0;
      dl->AddCircleFilled(ImVec2(float(px), float(py)), 7.f, sel ? IM_COL32(255, 200, 30, 255) : IM_COL32(220, 30, 30, 255));
      dl->AddCircle(ImVec2(float(px), float(py)), 7.f, IM_COL32(60, 0, 0, 255), 0, 1.5f);
      dl->AddText(ImVec2(float(px) + 9, float(py) - 8), IM_COL32(120, 0, 0, 255), view.fingers[i].name.c_str());
    }
  }

  // The 2D pattern inset: bottom right, a third of the window's height (GL, see Renderer::prepare_pattern).
  // Reads the simulation (the inset's layer is redrawn when the pattern changed); show_pattern_inset
  // copies the layer to the window.
  void prepare_pattern_inset(int fw, int fh) {
    inset_rect[2] = inset_rect[3] = 0;
    if (!show_pattern) return;
    Vec2 lo = Vec2::Constant(1e300), hi = Vec2::Constant(-1e300);
    for (const Vec2& p : scenario.outline) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const double aspect = (hi.x() - lo.x()) / std::max(1e-9, hi.y() - lo.y());
    int h = fh * 2 / 5, w = static_cast<int>(h * aspect);
    if (w > fw / 3) {
      w = fw / 3;
      h = static_cast<int>(w / aspect);
    }
    const std::vector<int> sel(selected.begin(), selected.end());
    renderer.prepare_pattern(*sim, w, h, sel);
    inset_rect[0] = fw - w - 10;
    inset_rect[1] = 10;
    inset_rect[2] = w;
    inset_rect[3] = h;
    glViewport(0, 0, fw, fh);
  }

  void show_pattern_inset() {
    if (inset_rect[2] > 0) renderer.show_pattern(inset_rect[0], inset_rect[1], inset_rect[2], inset_rect[3]);
  }

  void panel() {
    ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
    ImGui::SetNextWindowSize(ImVec2(340, 0), ImGuiCond_FirstUseEver);
    ImGui::Begin("papertear");
    ImGui::Text("%s", scenario.name.c_str());
    ImGui::Text("frame %d   t = %.2f s   %.1f FPS", view.frame, view.time, ImGui::GetIO().Framerate);
    if (lockstep()) ImGui::Text("lockstep: one step per frame");
    else ImGui::Text("simulation at %.2fx real time", sim_clock.speed());
    ImGui::Text("%d triangles, %d vertices, %zu tears, %d pieces", view.triangles, view.vertices, view.tears,
                view.pieces);
    ImGui::Text("step %.2f ms (avg %.2f), pick %.1f us (max %.1f)", sim_ms.count ? sim_ms.v[(sim_ms.head + 239) % 240] : 0.f,
                sim_ms.avg(), last_pick_us, max_pick_us);
    if (ImGui::Button(playing ? "Pause" : "Play")) playing = !playing;
    ImGui::SameLine();
    if (ImGui::Button("Step")) step_once = true;
    ImGui::SameLine();
    if (ImGui::Button("Reset")) reset();
    ImGui::SameLine();
    ImGui::Checkbox("wire", &wireframe);
    ImGui::SameLine();
    ImGui::Checkbox("pattern", &show_pattern);

    if (ImGui::CollapsingHeader("Material and tearing", ImGuiTreeNodeFlags_DefaultOpen)) {
      ImGui::TextDisabled("live (from the next frame):");
      const double zero = 0, one = 1, s_lo = 1e-9, s_hi = 1e-5, m_lo = 1e-4, m_hi = 0.05, sg_lo = 1e-5, sg_hi = 2e-3;
      edits.material_edited |= ImGui::DragScalar("fracture c (J/m2)", ImGuiDataType_Double, &edits.fracture_c, 50.0f);
      edits.fracture_c = std::max(1.0, edits.fracture_c);
      edits.material_edited |=
          ImGui::SliderScalar("tip damage D", ImGuiDataType_Double, &edits.tip_damage, &zero, &one, "%.3f");
      edits.propagation_edited |= ImGui::SliderScalar("speed k", ImGuiDataType_Double, &edits.speed, &s_lo, &s_hi,
                                                      "%.2e", ImGuiSliderFlags_Logarithmic);
      edits.propagation_edited |= ImGui::SliderScalar("max step (m)", ImGuiDataType_Double, &edits.max_step, &m_lo,
                                                      &m_hi, "%.4f", ImGuiSliderFlags_Logarithmic);
      edits.detail_edited |= ImGui::SliderScalar("sigma (m)", ImGuiDataType_Double, &edits.sigma, &sg_lo, &sg_hi,
                                                 "%.2e", ImGuiSliderFlags_Logarithmic);
      edits.detail_edited |= ImGui::SliderScalar("omega", ImGuiDataType_Double, &edits.omega, &zero, &one, "%.3f");
      // Sliders clamp what is dragged, not what is typed (Ctrl+click): keep the engine's ranges.
      edits.speed = std::clamp(edits.speed, 0.0, 1.0);
      edits.max_step = std::clamp(edits.max_step, m_lo, 1.0);
      edits.sigma = std::clamp(edits.sigma, 0.0, 1.0);
      edits.omega = std::clamp(edits.omega, 0.0, 1.0);
      ImGui::TextDisabled("applied on Reset:");
      const double t_lo = 2e-5, t_hi = 1e-3;
      if (ImGui::SliderScalar("thickness e (m)", ImGuiDataType_Double, &thickness, &t_lo, &t_hi, "%.2e",
                              ImGuiSliderFlags_Logarithmic))
        pending_reset_params = true;
      if (ImGui::Combo("tear rule", &direction, kDirections, 3)) pending_reset_params = true;
      if (ImGui::IsItemHovered())
        ImGui::SetTooltip("tension_rays: the fingers' pulls along their shortest paths in the pattern;\n"
                          "fan: eq. 4-6 on the tip's own triangles (the paper's rule);\n"
                          "material_force: the J-integral's direction over 4 cm around the tip");
      if (pending_reset_params) ImGui::TextColored(ImVec4(1, 0.7f, 0.2f, 1), "Reset (R) to apply");
      ImGui::TextDisabled("recording saves the current values");
    }

    if (ImGui::CollapsingHeader("Timings (ms, Table 1 groups)", ImGuiTreeNodeFlags_DefaultOpen)) {
      static const char* names[5] = {"physics", "geometry", "tearing", "carving", "frame"};
      for (int k = 0; k < 5; ++k) {
        const Series& se = series[k];
        char overlay[64];
        std::snprintf(overlay, sizeof overlay, "%s avg %.2f max %.2f", names[k], se.avg(), se.max());
        ImGui::PlotLines(names[k], se.v.data(), static_cast<int>(se.v.size()), se.head, overlay, 0.0f,
                         std::max(0.1f, se.max() * 1.1f), ImVec2(0, 36));
      }
      char overlay[64];
      std::snprintf(overlay, sizeof overlay, "render avg %.2f max %.2f", render_ms.avg(), render_ms.max());
      ImGui::PlotLines("render", render_ms.v.data(), static_cast<int>(render_ms.v.size()), render_ms.head, overlay,
                       0.0f, std::max(0.1f, render_ms.max() * 1.1f), ImVec2(0, 36));
    }

    if (ImGui::CollapsingHeader("Fingers", ImGuiTreeNodeFlags_DefaultOpen)) {
      for (int i = 0; i < static_cast<int>(view.fingers.size()); ++i) {
        const FingerView& f = view.fingers[i];
        char label[160];
        std::snprintf(label, sizeof label, "%s  uv (%.3f, %.3f)  |F| %.2f N%s", f.name.c_str(), f.uv.x(), f.uv.y(),
                      f.force, f.active ? "" : (f.released ? "  released" : "  waiting"));
        if (ImGui::Selectable(label, selected.count(i) > 0) && finger_active(i)) {
          if (!ImGui::GetIO().KeyCtrl) selected.clear();
          selected.insert(i);
        }
      }
      if (ImGui::Button("Release selected")) {
        sync();
        for (int i : selected)
          if (finger_active(i)) sim->release_finger(i);
        capture_view();
        selected.clear();
      }
    }

    if (ImGui::CollapsingHeader("Scenario")) {
      ImGui::InputText("path", load_path, sizeof load_path);
      if (ImGui::Button("Load")) load(load_path);
      ImGui::SameLine();
      ImGui::TextDisabled("or drop a .json file on the window");
    }
    if (ImGui::CollapsingHeader("Record", ImGuiTreeNodeFlags_DefaultOpen)) {
      ImGui::InputText("file", record_path, sizeof record_path);
      if (ImGui::Button("Record session (Ctrl+S)")) record();
      ImGui::TextDisabled("papertear run <file> replays it");
    }
    if (ImGui::CollapsingHeader("Help")) {
      ImGui::TextWrapped(
          "Left click on the sheet: put a finger there; drag: move it in the view plane (Shift: depth). "
          "Left drag a finger: grab it (with the selected ones). Ctrl+click: select. Right click a finger: "
          "let go. Left drag elsewhere: orbit; right/middle drag: pan; wheel: zoom. Space play/pause, N "
          "step, R reset, G select all fingers (hand), Q/E rotate the selection about the view axis, Esc "
          "deselect, W wireframe, F frame, Ctrl+S record.");
    }
    if (!status.empty() && glfwGetTime() < status_until) ImGui::TextColored(ImVec4(0.4f, 1, 0.4f, 1), "%s", status.c_str());
    ImGui::End();
  }

  // --- frame --------------------------------------------------------------------------------------------

  // Draws a frame. A frame that owns the simulation writes the queued edits, uploads the vertex data and
  // the pattern inset and then starts `steps` simulation frames on the stepper, which run while this frame
  // and the next ones are drawn; a frame that does not own it draws what was uploaded last.
  void render_frame(int steps = 0) {
    int fw, fh;
    glfwGetFramebufferSize(window, &fw, &fh);
    int ww, wh;
    glfwGetWindowSize(window, &ww, &wh);
    camera.width = std::max(1, ww);
    camera.height = std::max(1, wh);
    const auto t0 = Clock::now();
    if (own) {
      ++frames_owning;
      apply_queued_edits(edits, *sim);
      renderer.prepare(*sim, wireframe);
      prepare_pattern_inset(fw, fh);
      prepare_ms.add(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      if (steps > 0) {
        own = false;
        stepper.start([this, steps] { advance(steps); });
      }
    }
    glViewport(0, 0, fw, fh);
    glClearColor(kBackground[0], kBackground[1], kBackground[2], kBackground[3]);
    // Stencil with depth: llvmpipe clears a packed depth-stencil buffer with plain stores only when both
    // are cleared (depth alone keeps the stencil bits: a read-modify-write of every pixel, ~1 ms here).
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
    renderer.draw_prepared(camera);
    show_pattern_inset();
    glFinish();
    const auto t1 = Clock::now();
    ImGui::Render();
    draw_ui(fw, fh);
    glFinish();
    const auto t2 = Clock::now();
    sheet_ms.add(std::chrono::duration<double, std::milli>(t1 - t0).count());
    ui_ms.add(std::chrono::duration<double, std::milli>(t2 - t1).count());
    render_ms.add(std::chrono::duration<double, std::milli>(t2 - t0).count());
  }

  // ImGui's draw data in two parts: the background list (finger markers, which follow the sheet) is
  // drawn every frame; the windows go through ui_layer. Drawing the panel (text, six plots, a translucent
  // background, all blended) costs llvmpipe 4-6 ms at 1280x800 on this 2-core machine; compositing it,
  // about one. The panel's numbers and plots therefore refresh kPanelPeriod apart, and every frame while
  // the mouse is over a window or a widget is active, on a click or key press (whatever they change
  // shows at once), on a resize. Dragging on the sheet does not redraw the panel.
  static constexpr double kPanelPeriod = 0.1;  // s: 10 Hz, like most frame-time overlays
  void draw_ui(int fw, int fh) {
    ImDrawData* dd = ImGui::GetDrawData();
    if (!dd || !dd->Valid) return;
    ImDrawList* background = ImGui::GetBackgroundDrawList();
    std::vector<ImDrawList*> under, over;
    for (int i = 0; i < dd->CmdListsCount; ++i) (dd->CmdLists[i] == background ? under : over).push_back(dd->CmdLists[i]);
    auto part = [&](std::vector<ImDrawList*>& lists) {
      ImDrawData d = *dd;
      d.CmdLists = lists.data();
      d.CmdListsCount = static_cast<int>(lists.size());
      d.TotalVtxCount = d.TotalIdxCount = 0;
      for (const ImDrawList* l : lists) {
        d.TotalVtxCount += l->VtxBuffer.Size;
        d.TotalIdxCount += l->IdxBuffer.Size;
      }
      return d;
    };
    if (!under.empty()) {
      ImDrawData d = part(under);
      ImGui_ImplOpenGL3_RenderDrawData(&d);
    }

    const ImGuiIO& io = ImGui::GetIO();
    bool input = io.WantCaptureMouse || io.WantCaptureKeyboard || ImGui::IsAnyItemActive();
    for (int b = 0; b < 5 && !input; ++b) input = io.MouseClicked[b] || io.MouseReleased[b];
    for (int k = 0; k < 512 && !input; ++k) input = io.KeysDownDuration[k] == 0.0f;
    const double now = glfwGetTime();
    if (ui_refresh || input || now - ui_drawn_at >= kPanelPeriod || ui_layer.width() != fw ||
        ui_layer.height() != fh) {
      ui_refresh = false;
      ui_drawn_at = now;
      ImDrawData d = part(over);
      ui_layer.begin(fw, fh);
      ImGui_ImplOpenGL3_RenderDrawData(&d);
      ui_layer.end();
      flat_stale = true;
      // The rectangle the windows cover (their vertices, 2 px wider for antialiased edges), GL pixels.
      float lo_x = 1e30f, lo_y = 1e30f, hi_x = -1e30f, hi_y = -1e30f;
      for (const ImDrawList* l : over)
        for (const ImDrawVert& v : l->VtxBuffer) {
          lo_x = std::min(lo_x, v.pos.x);
          lo_y = std::min(lo_y, v.pos.y);
          hi_x = std::max(hi_x, v.pos.x);
          hi_y = std::max(hi_y, v.pos.y);
        }
      if (lo_x > hi_x) {
        ui_rect[2] = ui_rect[3] = 0;
      } else {
        const float sx = dd->FramebufferScale.x, sy = dd->FramebufferScale.y;
        const int x0 = std::max(0, static_cast<int>(std::floor((lo_x - dd->DisplayPos.x) * sx)) - 2);
        const int x1 = std::min(fw, static_cast<int>(std::ceil((hi_x - dd->DisplayPos.x) * sx)) + 2);
        const int y0 = std::max(0, static_cast<int>(std::floor((lo_y - dd->DisplayPos.y) * sy)) - 2);
        const int y1 = std::min(fh, static_cast<int>(std::ceil((hi_y - dd->DisplayPos.y) * sy)) + 2);
        ui_rect[0] = x0;
        ui_rect[1] = fh - y1;
        ui_rect[2] = x1 - x0;
        ui_rect[3] = y1 - y0;
      }
    }
    // Where only the background lies behind the windows, copying ui_flat gives the same pixels as
    // blending ui_layer, at a fraction of the cost; otherwise (the sheet, a finger marker or the inset
    // behind the panel) blend.
    const int* r = ui_rect;
    if (r[2] > 0 && r[3] > 0) {
      if (behind_windows_is_background(fw, fh, under)) {
        if (flat_stale) {
          ui_flat.begin(fw, fh, kBackground);
          ui_layer.composite(r[0], r[1], r[2], r[3]);
          ui_flat.end();
          flat_stale = false;
        }
        ui_flat.copy_to_window(r[0], r[1], r[2], r[3], r[0], r[1]);
      } else {
        ui_layer.composite(r[0], r[1], r[2], r[3]);
      }
    }
    glViewport(0, 0, fw, fh);
  }
  bool flat_stale = true;

  // Whether nothing but the cleared background lies under ui_rect: the sheet's projected bounding box
  // (its vertices, 4 px wider for the edge lines), the background draw list and the inset stay clear.
  bool behind_windows_is_background(int fw, int fh, const std::vector<ImDrawList*>& under) const {
    const double x0 = ui_rect[0], y0 = ui_rect[1], x1 = x0 + ui_rect[2], y1 = y0 + ui_rect[3];
    auto clear_of = [&](double lx, double ly, double hx, double hy) { return hx < x0 || lx > x1 || hy < y0 || ly > y1; };
    if (inset_rect[2] > 0 && !clear_of(inset_rect[0], inset_rect[1], inset_rect[0] + inset_rect[2], inset_rect[1] + inset_rect[3]))
      return false;
    const double sx = double(fw) / camera.width, sy = double(fh) / camera.height;  // window → GL pixels
    for (const ImDrawList* l : under)
      for (const ImDrawVert& v : l->VtxBuffer)
        if (!clear_of(v.pos.x * sx - 2, fh - v.pos.y * sy - 2, v.pos.x * sx + 2, fh - v.pos.y * sy + 2)) return false;
    const Eigen::Matrix4d pv = camera.projection() * camera.view();
    double lx = 1e300, ly = 1e300, hx = -1e300, hy = -1e300;
    for (const Vec3& p : view.positions) {
      const Eigen::Vector4d c = pv * Eigen::Vector4d(p.x(), p.y(), p.z(), 1.0);
      if (!(c.w() > 0)) return false;  // behind the eye: its projection is unbounded
      const double gx = (c.x() / c.w() * 0.5 + 0.5) * fw, gy = (c.y() / c.w() * 0.5 + 0.5) * fh;
      lx = std::min(lx, gx);
      ly = std::min(ly, gy);
      hx = std::max(hx, gx);
      hy = std::max(hy, gy);
    }
    return lx > hx || clear_of(lx - 4, ly - 4, hx + 4, hy + 4);
  }

  bool save_png(const std::string& path) {
    int fw, fh;
    glfwGetFramebufferSize(window, &fw, &fh);
    std::vector<unsigned char> px(static_cast<size_t>(fw) * fh * 4), flipped(px.size());
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadBuffer(GL_BACK);
    glReadPixels(0, 0, fw, fh, GL_RGBA, GL_UNSIGNED_BYTE, px.data());
    for (int y = 0; y < fh; ++y)
      std::memcpy(&flipped[static_cast<size_t>(y) * fw * 4], &px[static_cast<size_t>(fh - 1 - y) * fw * 4],
                  static_cast<size_t>(fw) * 4);
    for (size_t i = 3; i < flipped.size(); i += 4) flipped[i] = 255;
    const fs::path target(path);
    std::error_code ec;
    if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
    return stbi_write_png(path.c_str(), fw, fh, 4, flipped.data(), fw * 4) != 0;
  }

  // Scripted mouse for headless checks of the interactive path (picking, attach, drag, rotate, release):
  // frame 2 clicks the sheet left of its top centre and frame 4 right of it (grabbing both as a hand);
  // the hand is dragged apart in the view plane and turned (Q), then let go at 3/4 of the run.
  Vec2 demo_uv(int k) const {
    Vec2 lo = Vec2::Constant(1e300), hi = Vec2::Constant(-1e300);
    for (const Vec2& p : scenario.outline) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    return Vec2(lo.x() + (k == 0 ? 0.36 : 0.64) * (hi.x() - lo.x()), lo.y() + 0.93 * (hi.y() - lo.y()));
  }
  void demo_input(int f) {
    auto screen_of = [&](const Vec2& uv, double& px, double& py) {
      sync();  // reads the vertices; the drag below goes through the queue like a user's
      const Sheet& s = sim->sheet();
      int best = 0;
      for (int v = 1; v < s.verts.size(); ++v)
        if ((s.verts.rest[v] - uv).squaredNorm() < (s.verts.rest[best] - uv).squaredNorm()) best = v;
      return camera.project(s.verts.x[best], px, py);
    };
    double px, py;
    if (f == 2 && screen_of(demo_uv(0), px, py)) {
      press_left(px, py, 0);
      drag = Drag{};
    }
    if (f == 4 && screen_of(demo_uv(1), px, py)) {
      press_left(px, py, GLFW_MOD_CONTROL);  // ctrl on empty sheet: nothing; plain click below
      press_left(px, py, 0);
      drag = Drag{};
      selected.clear();
      for (int i = 0; i < static_cast<int>(view.fingers.size()); ++i)
        if (finger_active(i)) selected.insert(i);  // G
    }
    const int end = std::max(8, opt.frames * 3 / 4);
    if (f > 4 && f < end && selected.size() >= 2) {
      // Pull the second finger away from the first in the view plane, a few pixels per frame.
      const int second = *selected.rbegin();
      if (camera.project(finger_position(second), px, py)) {
        Drag keep = drag;
        drag = Drag{};
        drag.mode = Drag::Finger;
        drag.finger = second;
        drag.plane_point = finger_goal(second);
        drag.start = {{second, finger_goal(second)}};
        drag.last_x = px;
        drag.last_y = py;
        drag_to(px + 3, py - 1, 0);
        drag = keep;
      }
      if (f % 4 == 0) rotate_selection(0.01);  // Q held now and then
    }
    if (f == end)
      for (int i : std::set<int>(selected)) {
        if (camera.project(finger_position(i), px, py)) release_at(px, py);
      }
  }

  int run() {
    const bool headless = opt.frames >= 0;
    const double frame_dt = 1.0 / scenario.sim.fps;
    int frames_done = 0, sim_frames = 0;
    double last = glfwGetTime();
    const auto wall0 = Clock::now();
    while (!glfwWindowShouldClose(window)) {
      glfwPollEvents();
      const double now = glfwGetTime();
      const double dt = std::min(0.1, now - last);
      last = now;
      unclocked += dt;
      // Lockstep waits for the step (one per drawn frame); otherwise a frame owns the simulation only when
      // the last step has finished, and draws the last uploaded state when it has not.
      if (lockstep()) sync();
      else if (!own && !stepper.busy()) sync();
      if (own) capture_view();
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      if (!dropped_path.empty()) {
        load(dropped_path);
        dropped_path.clear();
      }
      if (!headless) handle_input(dt);
      else if (opt.demo_drag) demo_input(frames_done);
      int steps = 0;
      if (own) {
        if (lockstep() || step_once) {
          steps = 1;
          step_once = false;
        } else if (playing) {
          steps = sim_clock.due(unclocked, frame_dt);
        }
        unclocked = 0;
      }
      sim_frames += steps;
      panel();
      draw_finger_markers();
      render_frame(steps);
      if (headless && ++frames_done >= opt.frames) break;
      glfwSwapBuffers(window);
    }
    sync();
    if (headless) {
      const double wall = std::chrono::duration<double>(Clock::now() - wall0).count();
      sim->flush();
      if (!opt.record.empty()) record_to(opt.record);
      std::printf("papertear-viewer: %d frames in %.2f s: %.1f frames/s, %d simulation frames (%.2fx real time%s; "
                  "%lld frames read the simulation, the others drew the last state while a step ran; "
                  "sim step avg %.2f ms, render avg %.2f ms: sheet %.2f (reading the simulation %.2f), ui %.2f), %d "
                  "triangles, %zu tears\n",
                  frames_done, wall, frames_done / std::max(1e-9, wall), sim_frames,
                  sim_frames * frame_dt / std::max(1e-9, wall), lockstep() ? ", lockstep" : "",
                  static_cast<long long>(frames_owning), sim_ms.avg(),
                  render_ms.avg(), sheet_ms.avg(), prepare_ms.avg(), ui_ms.avg(),
                  sim->sheet().tris.size(), sim->sheet().tears.size());
      if (!opt.screenshot.empty()) {
        // Render once more after flush so the last carved details show, then read the back buffer.
        ImGui_ImplOpenGL3_NewFrame();
        ImGui_ImplGlfw_NewFrame();
        ImGui::NewFrame();
        panel();
        draw_finger_markers();
        ui_refresh = true;  // the picture shows the panel as of this frame
        render_frame();
        if (!save_png(opt.screenshot)) {
          std::fprintf(stderr, "papertear-viewer: cannot write %s\n", opt.screenshot.c_str());
          return kExitInternal;
        }
        std::printf("papertear-viewer: wrote %s\n", opt.screenshot.c_str());
      }
    }
    return kExitOk;
  }
};

// GLFW's last error, told in the one line of the failure it causes (printed as it came, a failed
// glfwInit was two lines: GLFW's reason, then ours). An error nothing fails on (the MSAA window refused
// before the one without) is not a failure and prints nothing.
std::string last_glfw_error;
void keep_glfw_error(int code, const char* message) {
  last_glfw_error = "glfw " + std::to_string(code) + ": " + (message ? message : "");
}
std::string glfw_reason() { return last_glfw_error.empty() ? "" : " (" + last_glfw_error + ")"; }

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse_args(argc, argv, opt)) return kExitInput;
  // As papertear's --threads: TBB runs no more than the CPUs this process may use, and asked for more it
  // prints a warning of its own.
  opt.threads = std::min(opt.threads, std::max(1, static_cast<int>(tbb::info::default_concurrency())));
  auto app = std::make_unique<App>();
  app->opt = opt;
  try {
    app->scenario = load_initial(opt.scenario, opt.settings);
  } catch (const InputError& e) {
    std::fprintf(stderr, "papertear-viewer: %s\n", e.what());
    return kExitInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "papertear-viewer: %s\n", e.what());
    return kExitInput;
  }

  glfwSetErrorCallback(keep_glfw_error);
  if (!glfwInit()) {
    std::fprintf(stderr, "papertear-viewer: cannot initialise GLFW%s: no display? try xvfb-run -a\n",
                 glfw_reason().c_str());
    return kExitInternal;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GL_TRUE);
  glfwWindowHint(GLFW_SAMPLES, opt.samples);
  const std::string title = "papertear-viewer — " + app->scenario.name;
  app->window = glfwCreateWindow(opt.width, opt.height, title.c_str(), nullptr, nullptr);
  if (!app->window) {
    glfwWindowHint(GLFW_SAMPLES, 0);
    app->window = glfwCreateWindow(opt.width, opt.height, title.c_str(), nullptr, nullptr);
  }
  if (!app->window) {
    std::fprintf(stderr, "papertear-viewer: cannot create an OpenGL 3.3 core window%s\n", glfw_reason().c_str());
    glfwTerminate();
    return kExitInternal;
  }
  glfwMakeContextCurrent(app->window);
  glfwSetWindowUserPointer(app->window, app.get());
  glfwSetDropCallback(app->window, [](GLFWwindow* w, int count, const char** paths) {
    if (count > 0) static_cast<App*>(glfwGetWindowUserPointer(w))->dropped_path = paths[0];
  });
  glfwSwapInterval(opt.frames >= 0 ? 0 : 1);

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(app->window, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");

  int status = kExitOk;
  try {
    if (!app->renderer.init()) throw std::runtime_error("OpenGL initialisation failed");
    app->take_parameters_from_scenario();
    std::snprintf(app->load_path, sizeof app->load_path, "%s", opt.scenario.c_str());
    app->reset();
    app->camera.frame_sheet(app->sim->sheet(), app->scenario.sim.gravity);
    status = app->run();
  } catch (const InputError& e) {
    std::fprintf(stderr, "papertear-viewer: %s\n", e.what());
    status = kExitInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "papertear-viewer: %s\n", e.what());
    status = kExitInternal;
  }
  app->sim.reset();
  app.reset();  // GL objects before the context goes
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwTerminate();
  return status;
}

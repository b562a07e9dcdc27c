// icube-view: keyboard, mouse and gamepad; see app.h.
#include "app.h"

#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace icube::viewer {

namespace {

int glfw_key(const std::string& k) {
  static const std::map<std::string, int> m = {
      {"W", GLFW_KEY_W}, {"A", GLFW_KEY_A}, {"S", GLFW_KEY_S}, {"D", GLFW_KEY_D}, {"UP", GLFW_KEY_UP},
      {"DOWN", GLFW_KEY_DOWN}, {"LEFT", GLFW_KEY_LEFT}, {"RIGHT", GLFW_KEY_RIGHT}, {"SPACE", GLFW_KEY_SPACE},
      {"SHIFT", GLFW_KEY_LEFT_SHIFT}, {"Q", GLFW_KEY_Q}, {"E", GLFW_KEY_E}};
  return m.at(k);
}

}  // namespace

bool App::held(const std::string& k) const {
  if (script_keys.count(k)) return true;
  if (ImGui::GetIO().WantCaptureKeyboard) return false;
  return glfwGetKey(window, glfw_key(k)) == GLFW_PRESS;
}

bool App::pressed(int key) {  // edge-triggered keyboard shortcut
  const bool now = glfwGetKey(window, key) == GLFW_PRESS && !ImGui::GetIO().WantCaptureKeyboard;
  const bool was = prev_keys[key];
  prev_keys[key] = now;
  return now && !was;
}

void App::shortcuts() {
  if (pressed(GLFW_KEY_ESCAPE)) quit = true;
  if (pressed(GLFW_KEY_TAB)) control = control == Control::Drive ? Control::Fly : Control::Drive;
  if (pressed(GLFW_KEY_C)) chase = !chase;
  if (pressed(GLFW_KEY_R)) toggle_continuous();
  if (pressed(GLFW_KEY_K)) keyframe();
  if (pressed(GLFW_KEY_P)) end_pass();
  if (pressed(GLFW_KEY_F12)) request_screenshot("");
  if (pressed(GLFW_KEY_F1)) show_ui = !show_ui;
  if (pressed(GLFW_KEY_Z)) ground.zero_height = !ground.zero_height;
  if (pressed(GLFW_KEY_G) && gauss && have_world) show_gaussians = !show_gaussians;
  if (pressed(GLFW_KEY_T) && timeline_frames() > 0) play_time = !play_time;
  for (int m = 0; m < 5; ++m)
    if (pressed(GLFW_KEY_1 + m)) shade.mode = static_cast<RenderMode>(m);
}

VehicleInput App::drive_input() {
  VehicleInput in;
  in.throttle = (held("W") || held("UP")) ? 1.0 : 0.0;
  in.brake = (held("S") || held("DOWN")) ? 1.0 : 0.0;
  if (held("SPACE")) in.brake = 1.0;
  in.steer = ((held("A") || held("LEFT")) ? 1.0 : 0.0) - ((held("D") || held("RIGHT")) ? 1.0 : 0.0);
  GLFWgamepadstate pad;
  if (glfwJoystickIsGamepad(GLFW_JOYSTICK_1) && glfwGetGamepadState(GLFW_JOYSTICK_1, &pad)) {
    const double steer = -pad.axes[GLFW_GAMEPAD_AXIS_LEFT_X];
    const double rt = 0.5 * (double(pad.axes[GLFW_GAMEPAD_AXIS_RIGHT_TRIGGER]) + 1.0);
    const double lt = 0.5 * (double(pad.axes[GLFW_GAMEPAD_AXIS_LEFT_TRIGGER]) + 1.0);
    if (std::fabs(steer) > 0.1) in.steer = steer;
    in.throttle = std::max(in.throttle, rt > 0.05 ? rt : 0.0);
    in.brake = std::max(in.brake, lt > 0.05 ? lt : 0.0);
  }
  return in;
}

void App::fly_update(double dt) {
  const double speed = (held("SHIFT") ? 40.0 : 10.0) * dt;
  glm::dvec3 move(0.0);
  if (held("W") || held("UP")) move += fly_forward(fly);
  if (held("S") || held("DOWN")) move -= fly_forward(fly);
  if (held("A") || held("LEFT")) move += fly_left(fly);
  if (held("D") || held("RIGHT")) move -= fly_left(fly);
  if (held("E")) move.z += 1.0;
  if (held("Q")) move.z -= 1.0;
  GLFWgamepadstate pad;
  if (glfwJoystickIsGamepad(GLFW_JOYSTICK_1) && glfwGetGamepadState(GLFW_JOYSTICK_1, &pad)) {
    auto dz = [](float v) { return std::fabs(v) > 0.12f ? double(v) : 0.0; };
    move += -dz(pad.axes[GLFW_GAMEPAD_AXIS_LEFT_Y]) * fly_forward(fly) - dz(pad.axes[GLFW_GAMEPAD_AXIS_LEFT_X]) * fly_left(fly);
    fly.yaw -= 2.0 * dt * dz(pad.axes[GLFW_GAMEPAD_AXIS_RIGHT_X]);
    fly.pitch -= 1.5 * dt * dz(pad.axes[GLFW_GAMEPAD_AXIS_RIGHT_Y]);
  }
  fly.position += speed * move;
  // Mouse look: hold the right button.
  double mx = 0.0, my = 0.0;
  glfwGetCursorPos(window, &mx, &my);
  const bool down = glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS && !ImGui::GetIO().WantCaptureMouse;
  if (down && mouse_look) {
    fly.yaw -= 0.004 * (mx - mouse_x);
    fly.pitch -= 0.004 * (my - mouse_y);
  }
  mouse_look = down;
  mouse_x = mx;
  mouse_y = my;
  fly.pitch = std::clamp(fly.pitch, -1.5, 1.5);
}

bool App::moving() const {
  if (control == Control::Drive) return std::fabs(car.speed) > 0.3;
  if (control == Control::Replay) return true;
  return mouse_look || held("W") || held("A") || held("S") || held("D") || held("Q") || held("E");
}

}  // namespace icube::viewer

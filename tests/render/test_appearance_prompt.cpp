// The appearance renderer's prompt parser (engine/render/appearance/prompt.h)
// on a table of phrases in the style of InfiniCube's captions, unknown words,
// conflicts, and the lighting each prompt sets (lighting.h): the sun is up by
// day and down at night, rain wets the ground, snow covers it, fog shortens
// the visibility, and the exposure keeps night and dusk darker than noon.
#include <doctest/doctest.h>

#include "render/appearance/lighting.h"
#include "render/appearance/prompt.h"

#include <string>
#include <vector>

using namespace icube;
using render::Season;
using render::TimeOfDay;
using render::Weather;

TEST_CASE("appearance prompt: a table of caption phrases") {
  struct Row {
    const char* text;
    TimeOfDay time;
    Weather weather;
    Season season;
    std::vector<std::string> unknown;
  };
  const Row rows[] = {
      {render::kDefaultAppearancePrompt, TimeOfDay::Noon, Weather::Sunny, Season::Summer, {}},
      {"The video is capture by a camera mounted on a vehicle. The video is about a driving scene captured at daytime. "
       "The weather is clear.",
       TimeOfDay::Noon, Weather::Sunny, Season::Summer, {}},
      {"A driving scene at nighttime. It is snowing.", TimeOfDay::Night, Weather::Snowy, Season::Winter, {}},
      {"Partly cloudy morning", TimeOfDay::Morning, Weather::PartlyCloudy, Season::Summer, {}},
      {"heavy rain at dusk", TimeOfDay::Dusk, Weather::Rainy, Season::Summer, {}},
      {"FOGGY autumn afternoon", TimeOfDay::Afternoon, Weather::Foggy, Season::Autumn, {}},
      {"overcast sky in spring", TimeOfDay::Noon, Weather::Overcast, Season::Spring, {}},
      {"sunrise, misty", TimeOfDay::Dawn, Weather::Foggy, Season::Summer, {}},
      {"snowy day in the fall", TimeOfDay::Noon, Weather::Snowy, Season::Autumn, {}},
      {"purple dragons at night", TimeOfDay::Night, Weather::Sunny, Season::Summer, {"purple", "dragons"}},
      {"", TimeOfDay::Noon, Weather::Sunny, Season::Summer, {}},
  };
  for (const Row& r : rows) {
    CAPTURE(r.text);
    const render::AppearancePrompt p = render::parse_prompt(r.text);
    CHECK(p.time == r.time);
    CHECK(p.weather == r.weather);
    CHECK(p.season == r.season);
    CHECK(p.unknown == r.unknown);
  }
  const render::AppearancePrompt heavy = render::parse_prompt("heavy rain");
  CHECK(heavy.intensity > 1.0f);
  CHECK(render::parse_prompt("light snow").intensity < 1.0f);
  CHECK(render::parse_prompt("night, snowing").summary() == "night, snowy, winter");
}

TEST_CASE("appearance prompt: conflicting words, the last wins and a note says so") {
  const render::AppearancePrompt p = render::parse_prompt("a sunny day, then rainy");
  CHECK(p.weather == Weather::Rainy);
  REQUIRE(p.notes.size() == 1);
  CHECK(p.notes[0].find("rainy") != std::string::npos);
  CHECK(render::parse_prompt("dawn dusk").time == TimeOfDay::Dusk);
  CHECK(!render::prompt_vocabulary().empty());
}

TEST_CASE("appearance lighting: sun, weather and exposure follow the prompt") {
  const auto noon = render::lighting_params(render::parse_prompt("sunny noon"), 0);
  const auto night = render::lighting_params(render::parse_prompt("night"), 0);
  const auto dusk = render::lighting_params(render::parse_prompt("dusk"), 0);
  const auto rain = render::lighting_params(render::parse_prompt("rainy"), 0);
  const auto fog = render::lighting_params(render::parse_prompt("foggy"), 0);
  const auto snow = render::lighting_params(render::parse_prompt("snowy"), 0);
  CHECK((noon.flags & APPEARANCE_FLAG_SUN) != 0u);
  CHECK((night.flags & APPEARANCE_FLAG_SUN) == 0u);
  CHECK(noon.sun_z > 0.8f);
  CHECK(dusk.sun_z > 0.0f);
  CHECK(dusk.sun_z < 0.1f);
  // A low sun is red: blue suffers the longest path.
  CHECK(dusk.sun_b / dusk.sun_r < noon.sun_b / noon.sun_r);
  // The Preetham zenith is bright by day (kcd/m2) and the sky integral is positive.
  CHECK(noon.amb_up_g > 5.0f);
  CHECK(night.amb_up_g < 0.05f);
  CHECK(rain.wetness > 0.5f);
  CHECK(snow.snow > 0.5f);
  CHECK(fog.fog_density > 10.0f * noon.fog_density);
  // Exposure compensates only part of the light: the scene radiance times exposure is lower at night and dusk.
  const float e_noon = noon.exposure * (noon.amb_up_g + noon.sun_g * noon.sun_z);
  const float e_dusk = dusk.exposure * (dusk.amb_up_g + dusk.sun_g * dusk.sun_z);
  const float e_night = night.exposure * night.amb_up_g;
  CHECK(e_dusk < 0.7f * e_noon);
  CHECK(e_night < 0.1f * e_noon);
}

// The text prompt of Stage 2 as the procedural appearance renderer reads it:
// time of day, weather and season from the words InfiniCube's captions use
// (its captioner is told to use "daytime, nighttime, sunny, cloudy, rainy,
// snowing, etc."; its default prompt is "The video is about a driving scene
// captured at daytime. The weather is clear."). Words are matched case-
// insensitively after splitting on anything that is not a letter; filler words
// of such captions (the, video, driving, scene, ...) are skipped; every other
// word the parser does not know is listed in `unknown`, never silently dropped.
// When two words of one kind disagree (e.g. "sunny" and "rainy"), the last one
// wins and `notes` says so.
#pragma once

#include <string>
#include <vector>

namespace icube::render {

enum class TimeOfDay { Dawn, Morning, Noon, Afternoon, Dusk, Night };
enum class Weather { Sunny, PartlyCloudy, Overcast, Rainy, Foggy, Snowy };
enum class Season { Summer, Spring, Autumn, Winter };

const char* time_of_day_name(TimeOfDay t);
const char* weather_name(Weather w);
const char* season_name(Season s);

struct AppearancePrompt {
  TimeOfDay time = TimeOfDay::Noon;
  Weather weather = Weather::Sunny;
  Season season = Season::Summer;
  float intensity = 1.0f;  // "light" 0.5, "heavy"/"dense"/"thick" 1.5: rain, fog and snow strength
  bool season_given = false;
  std::vector<std::string> understood;  // the words that set something, in order
  std::vector<std::string> unknown;     // words neither understood nor filler
  std::vector<std::string> notes;       // conflicts resolved
  std::string summary() const;          // e.g. "dusk, rainy, summer"
};

// The default prompt (InfiniCube's) parses to noon, sunny, summer.
inline constexpr const char* kDefaultAppearancePrompt =
    "The video is about a driving scene captured at daytime. The weather is clear.";

AppearancePrompt parse_prompt(const std::string& text);

// One line per understood word: "word -> effect", for `--list-prompts`.
std::vector<std::string> prompt_vocabulary();

}  // namespace icube::render

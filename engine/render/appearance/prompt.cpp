// Prompt parsing for the procedural appearance renderer; see prompt.h.
#include "render/appearance/prompt.h"

#include <cctype>
#include <set>
#include <string_view>

namespace icube::render {

namespace {

enum class Kind { Time, Weather, Season, Intensity };

struct Word {
  std::string_view word;
  Kind kind;
  int value;                 // TimeOfDay / Weather / Season, or intensity in percent
  std::string_view effect;   // for prompt_vocabulary()
};

constexpr Word kWords[] = {
    {"daytime", Kind::Time, static_cast<int>(TimeOfDay::Noon), "time: midday sun"},
    {"day", Kind::Time, static_cast<int>(TimeOfDay::Noon), "time: midday sun"},
    {"noon", Kind::Time, static_cast<int>(TimeOfDay::Noon), "time: midday sun"},
    {"midday", Kind::Time, static_cast<int>(TimeOfDay::Noon), "time: midday sun"},
    {"morning", Kind::Time, static_cast<int>(TimeOfDay::Morning), "time: morning sun, 30 degrees high"},
    {"afternoon", Kind::Time, static_cast<int>(TimeOfDay::Afternoon), "time: afternoon sun, 30 degrees high"},
    {"dawn", Kind::Time, static_cast<int>(TimeOfDay::Dawn), "time: sun 4 degrees above the horizon, east"},
    {"sunrise", Kind::Time, static_cast<int>(TimeOfDay::Dawn), "time: sun 4 degrees above the horizon, east"},
    {"dusk", Kind::Time, static_cast<int>(TimeOfDay::Dusk), "time: sun 4 degrees above the horizon, west"},
    {"sunset", Kind::Time, static_cast<int>(TimeOfDay::Dusk), "time: sun 4 degrees above the horizon, west"},
    {"evening", Kind::Time, static_cast<int>(TimeOfDay::Dusk), "time: sun 4 degrees above the horizon, west"},
    {"twilight", Kind::Time, static_cast<int>(TimeOfDay::Dusk), "time: sun 4 degrees above the horizon, west"},
    {"night", Kind::Time, static_cast<int>(TimeOfDay::Night), "time: night, street lamps, headlights, lit windows"},
    {"nighttime", Kind::Time, static_cast<int>(TimeOfDay::Night), "time: night, street lamps, headlights, lit windows"},
    {"midnight", Kind::Time, static_cast<int>(TimeOfDay::Night), "time: night, street lamps, headlights, lit windows"},
    {"dark", Kind::Time, static_cast<int>(TimeOfDay::Night), "time: night, street lamps, headlights, lit windows"},
    {"clear", Kind::Weather, static_cast<int>(Weather::Sunny), "weather: clear sky (Preetham), hard shadows"},
    {"sunny", Kind::Weather, static_cast<int>(Weather::Sunny), "weather: clear sky (Preetham), hard shadows"},
    {"sunshine", Kind::Weather, static_cast<int>(Weather::Sunny), "weather: clear sky (Preetham), hard shadows"},
    {"bright", Kind::Weather, static_cast<int>(Weather::Sunny), "weather: clear sky (Preetham), hard shadows"},
    {"partly", Kind::Weather, static_cast<int>(Weather::PartlyCloudy), "weather: half overcast, softer sun"},
    {"cloudy", Kind::Weather, static_cast<int>(Weather::Overcast), "weather: overcast sky (CIE), no hard shadows"},
    {"overcast", Kind::Weather, static_cast<int>(Weather::Overcast), "weather: overcast sky (CIE), no hard shadows"},
    {"clouds", Kind::Weather, static_cast<int>(Weather::Overcast), "weather: overcast sky (CIE), no hard shadows"},
    {"grey", Kind::Weather, static_cast<int>(Weather::Overcast), "weather: overcast sky (CIE), no hard shadows"},
    {"gray", Kind::Weather, static_cast<int>(Weather::Overcast), "weather: overcast sky (CIE), no hard shadows"},
    {"rain", Kind::Weather, static_cast<int>(Weather::Rainy), "weather: overcast, wet dark road, puddles reflecting the sky"},
    {"rainy", Kind::Weather, static_cast<int>(Weather::Rainy), "weather: overcast, wet dark road, puddles reflecting the sky"},
    {"raining", Kind::Weather, static_cast<int>(Weather::Rainy), "weather: overcast, wet dark road, puddles reflecting the sky"},
    {"wet", Kind::Weather, static_cast<int>(Weather::Rainy), "weather: overcast, wet dark road, puddles reflecting the sky"},
    {"drizzle", Kind::Weather, static_cast<int>(Weather::Rainy), "weather: overcast, wet dark road, puddles reflecting the sky"},
    {"showers", Kind::Weather, static_cast<int>(Weather::Rainy), "weather: overcast, wet dark road, puddles reflecting the sky"},
    {"storm", Kind::Weather, static_cast<int>(Weather::Rainy), "weather: overcast, wet dark road, puddles reflecting the sky"},
    {"stormy", Kind::Weather, static_cast<int>(Weather::Rainy), "weather: overcast, wet dark road, puddles reflecting the sky"},
    {"fog", Kind::Weather, static_cast<int>(Weather::Foggy), "weather: distance fog (80 m visibility)"},
    {"foggy", Kind::Weather, static_cast<int>(Weather::Foggy), "weather: distance fog (80 m visibility)"},
    {"mist", Kind::Weather, static_cast<int>(Weather::Foggy), "weather: distance fog (80 m visibility)"},
    {"misty", Kind::Weather, static_cast<int>(Weather::Foggy), "weather: distance fog (80 m visibility)"},
    {"haze", Kind::Weather, static_cast<int>(Weather::Foggy), "weather: distance fog (80 m visibility)"},
    {"hazy", Kind::Weather, static_cast<int>(Weather::Foggy), "weather: distance fog (80 m visibility)"},
    {"snow", Kind::Weather, static_cast<int>(Weather::Snowy), "weather: snowing, white ground and roofs"},
    {"snowy", Kind::Weather, static_cast<int>(Weather::Snowy), "weather: snowing, white ground and roofs"},
    {"snowing", Kind::Weather, static_cast<int>(Weather::Snowy), "weather: snowing, white ground and roofs"},
    {"snowfall", Kind::Weather, static_cast<int>(Weather::Snowy), "weather: snowing, white ground and roofs"},
    {"spring", Kind::Season, static_cast<int>(Season::Spring), "season: fresh green foliage"},
    {"summer", Kind::Season, static_cast<int>(Season::Summer), "season: deep green foliage"},
    {"autumn", Kind::Season, static_cast<int>(Season::Autumn), "season: orange and yellow foliage"},
    {"fall", Kind::Season, static_cast<int>(Season::Autumn), "season: orange and yellow foliage"},
    {"winter", Kind::Season, static_cast<int>(Season::Winter), "season: bare brown-grey foliage"},
    {"light", Kind::Intensity, 50, "intensity: half the rain, fog or snow"},
    {"slight", Kind::Intensity, 50, "intensity: half the rain, fog or snow"},
    {"heavy", Kind::Intensity, 150, "intensity: 1.5 times the rain, fog or snow"},
    {"dense", Kind::Intensity, 150, "intensity: 1.5 times the rain, fog or snow"},
    {"thick", Kind::Intensity, 150, "intensity: 1.5 times the rain, fog or snow"},
};

// Filler words of driving-scene captions; skipped without a report.
const std::set<std::string_view>& filler_words() {
  static const std::set<std::string_view> w = {
      "a", "an", "the", "is", "are", "was", "be", "it", "its", "this", "that", "there", "and", "or", "with", "of", "in",
      "on", "at", "by", "to", "from", "for", "during", "under", "as", "video", "videos", "clip", "driving", "drive",
      "scene", "scenes", "street", "streets", "road", "roads", "city", "town", "urban", "captured", "capture",
      "recorded", "camera", "mounted", "vehicle", "car", "cars", "front", "view", "about", "weather", "condition",
      "conditions", "time", "sky", "skies", "with", "some", "very", "quite", "mostly", "fairly", "while", "shows",
      "showing", "lighting", "visible", "visibility", "season", "s"};
  return w;
}

std::vector<std::string> words_of(const std::string& text) {
  std::vector<std::string> out;
  std::string cur;
  for (const char ch : text) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (std::isalpha(c)) cur.push_back(static_cast<char>(std::tolower(c)));
    else if (!cur.empty()) out.push_back(std::move(cur)), cur.clear();
  }
  if (!cur.empty()) out.push_back(std::move(cur));
  return out;
}

}  // namespace

const char* time_of_day_name(TimeOfDay t) {
  switch (t) {
    case TimeOfDay::Dawn: return "dawn";
    case TimeOfDay::Morning: return "morning";
    case TimeOfDay::Noon: return "noon";
    case TimeOfDay::Afternoon: return "afternoon";
    case TimeOfDay::Dusk: return "dusk";
    case TimeOfDay::Night: return "night";
  }
  return "?";
}

const char* weather_name(Weather w) {
  switch (w) {
    case Weather::Sunny: return "clear";
    case Weather::PartlyCloudy: return "partly cloudy";
    case Weather::Overcast: return "overcast";
    case Weather::Rainy: return "rainy";
    case Weather::Foggy: return "foggy";
    case Weather::Snowy: return "snowy";
  }
  return "?";
}

const char* season_name(Season s) {
  switch (s) {
    case Season::Summer: return "summer";
    case Season::Spring: return "spring";
    case Season::Autumn: return "autumn";
    case Season::Winter: return "winter";
  }
  return "?";
}

std::string AppearancePrompt::summary() const {
  std::string s = std::string(time_of_day_name(time)) + ", " + weather_name(weather) + ", " + season_name(season);
  if (intensity != 1.0f) s += intensity < 1.0f ? " (light)" : " (heavy)";
  return s;
}

AppearancePrompt parse_prompt(const std::string& text) {
  AppearancePrompt p;
  bool time_set = false, weather_set = false, partly = false;
  for (const std::string& w : words_of(text)) {
    const Word* hit = nullptr;
    for (const Word& k : kWords)
      if (k.word == w) hit = &k;
    // "light" is both an intensity and a filler ("street light"); the table wins.
    if (!hit) {
      if (!filler_words().count(w)) p.unknown.push_back(w);
      continue;
    }
    p.understood.push_back(w);
    switch (hit->kind) {
      case Kind::Time: {
        const auto t = static_cast<TimeOfDay>(hit->value);
        if (time_set && t != p.time)
          p.notes.push_back(std::string("time: '") + w + "' overrides " + time_of_day_name(p.time));
        p.time = t;
        time_set = true;
        break;
      }
      case Kind::Weather: {
        auto v = static_cast<Weather>(hit->value);
        if (v == Weather::PartlyCloudy) {
          partly = true;
          continue;
        }
        if (partly && v == Weather::Overcast) v = Weather::PartlyCloudy;
        partly = false;
        if (weather_set && v != p.weather)
          p.notes.push_back(std::string("weather: '") + w + "' overrides " + weather_name(p.weather));
        p.weather = v;
        weather_set = true;
        break;
      }
      case Kind::Season: {
        const auto s = static_cast<Season>(hit->value);
        if (p.season_given && s != p.season)
          p.notes.push_back(std::string("season: '") + w + "' overrides " + season_name(p.season));
        p.season = s;
        p.season_given = true;
        break;
      }
      case Kind::Intensity: p.intensity = static_cast<float>(hit->value) / 100.0f; break;
    }
  }
  if (partly && !weather_set) p.weather = Weather::PartlyCloudy;  // "partly" alone
  // Snow without a season is winter.
  if (p.weather == Weather::Snowy && !p.season_given) p.season = Season::Winter;
  return p;
}

std::vector<std::string> prompt_vocabulary() {
  std::vector<std::string> out;
  for (const Word& k : kWords) out.push_back(std::string(k.word) + " -> " + std::string(k.effect));
  out.push_back("(skipped as filler: the, video, driving, scene, captured, camera, weather, ...)");
  return out;
}

}  // namespace icube::render

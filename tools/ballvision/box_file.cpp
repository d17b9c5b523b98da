#include "tools/ballvision/box_file.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

namespace bv::cli {
namespace {

constexpr const char* kClassNames[] = {"ball", "obstacle", "human", "parking", "goal_post"};
constexpr int kClassCount = 5;

bool ParseFloat(const std::string& s, float& out) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v)) return false;
  out = static_cast<float>(v);
  return true;
}

}  // namespace

int AnnotatedImage::BallCount() const {
  int n = 0;
  for (const AnnotatedBox& b : boxes) n += b.class_id == 0;
  return n;
}

bool LoadAnnotations(const std::string& file, const std::string& image_dir,
                     std::vector<AnnotatedImage>& out, std::string& error) {
  out.clear();
  std::ifstream in(file);
  if (!in) {
    error = file + ": cannot open";
    return false;
  }
  std::map<std::string, size_t> pos;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos || line[0] == '#') continue;
    std::stringstream ss(line);
    std::vector<std::string> t;
    for (std::string w; ss >> w;) t.push_back(w);
    const std::string where = file + ":" + std::to_string(lineno) + ": ";
    if (!pos.count(t[0])) {
      pos[t[0]] = out.size();
      out.push_back(AnnotatedImage{t[0], image_dir + "/" + t[0], {}, lineno});
    }
    if (t.size() == 1) continue;
    // image id name... x0 y0 x1 y1 [cu cv w h]: the name may have spaces, so the numbers are
    // taken from the end.
    const size_t numbers = t.size() >= 11 ? 8 : 4;
    if (t.size() < 3 + numbers) {
      error = where + "expected 'image class_id class_name x0 y0 x1 y1 [cu cv w h]'";
      return false;
    }
    AnnotatedBox b;
    b.line = lineno;
    char* end = nullptr;
    const long id = std::strtol(t[1].c_str(), &end, 10);
    std::string name;
    for (size_t i = 2; i < t.size() - numbers; ++i) name += (name.empty() ? "" : " ") + t[i];
    std::string spelled = name;  // obj.names writes "goal post", the box files "goal_post"
    std::replace(spelled.begin(), spelled.end(), ' ', '_');
    if (end != t[1].c_str() + t[1].size() || id < 0 || id >= kClassCount ||
        spelled != kClassNames[id]) {
      error = where + "unknown class '" + t[1] + " " + name +
              "' (known: 0 ball, 1 obstacle, 2 human, 3 parking, 4 goal_post)";
      return false;
    }
    b.class_id = static_cast<int>(id);
    const size_t first = t.size() - numbers;
    if (!ParseFloat(t[first], b.u0) || !ParseFloat(t[first + 1], b.v0) ||
        !ParseFloat(t[first + 2], b.u1) || !ParseFloat(t[first + 3], b.v1)) {
      error = where + "box corners are not numbers";
      return false;
    }
    if (b.u1 < b.u0 || b.v1 < b.v0) {
      error = where + "box has x1 < x0 or y1 < y0";
      return false;
    }
    out[pos[t[0]]].boxes.push_back(b);
  }
  if (out.empty()) {
    error = file + ": no image listed (empty box file)";
    return false;
  }
  return true;
}

bool AddAnnotations(const std::string& file, std::vector<AnnotatedImage>& images,
                    std::string& error) {
  std::vector<AnnotatedImage> more;
  if (!LoadAnnotations(file, "", more, error)) return false;
  std::map<std::string, size_t> pos;
  for (size_t i = 0; i < images.size(); ++i) pos[images[i].name] = i;
  for (const AnnotatedImage& m : more) {
    if (!pos.count(m.name)) {
      error = file + ":" + std::to_string(m.line) + ": image " + m.name +
              " is not in the box file it adds to";
      return false;
    }
  }
  for (const AnnotatedImage& m : more) {
    std::vector<AnnotatedBox>& to = images[pos[m.name]].boxes;
    to.insert(to.end(), m.boxes.begin(), m.boxes.end());
  }
  return true;
}

bool CheckBoxesInside(const std::string& file, const AnnotatedImage& image, int width, int height,
                      std::string& error) {
  for (const AnnotatedBox& b : image.boxes) {
    if (b.u0 < -1.0f || b.v0 < -1.0f || b.u1 > static_cast<float>(width) + 1.0f ||
        b.v1 > static_cast<float>(height) + 1.0f) {
      std::ostringstream o;
      o << file << ":" << b.line << ": " << kClassNames[b.class_id] << " box (" << b.u0 << ", "
        << b.v0 << ")-(" << b.u1 << ", " << b.v1 << ") lies outside " << image.name << " (" << width
        << "x" << height << ")";
      error = o.str();
      return false;
    }
  }
  return true;
}

std::string ImageSet(const std::string& name) {
  const size_t a = name.find('_');
  const size_t b = a == std::string::npos ? a : name.find('_', a + 1);
  if (b != std::string::npos) return name.substr(0, b);
  const size_t dot = name.rfind('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

std::vector<AnnotatedImage> SplitImages(const std::vector<AnnotatedImage>& images,
                                        const std::string& split) {
  std::vector<AnnotatedImage> out;
  for (size_t i = 0; i < images.size(); ++i) {
    if (split == "all" || (split == "even" && i % 2 == 0) || (split == "odd" && i % 2 == 1)) {
      out.push_back(images[i]);
    }
  }
  return out;
}

}  // namespace bv::cli

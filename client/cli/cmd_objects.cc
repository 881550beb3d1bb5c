// objects add|list|remove, where, near: the object database and object-location queries.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "client/cli/commands.h"
#include "client/cli/json_views.h"

namespace semmap::cli {
namespace {

constexpr char kObjectsUsage[] =
    "usage: semmap objects add LABEL IMAGE... [--colour R,G,B] [--map M]\n"
    "       semmap objects list [--map M]\n"
    "       semmap objects remove LABEL [--map M]\n"
    "  The object database: photos of an object (a crop, or a photo with little background)\n"
    "  are registered under a label; keyframes streamed from then on are searched for it.\n"
    "  Objects are global (recognised in every map) unless --map names one.\n";

// "R,G,B" with each channel in 0..255.
std::optional<std::array<uint8_t, 3>> ParseColour(const std::string& text) {
  std::array<uint8_t, 3> rgb{};
  std::istringstream in(text);
  for (int i = 0; i < 3; ++i) {
    int v = -1;
    char comma = ',';
    if (!(in >> v) || v < 0 || v > 255) return std::nullopt;
    if (i < 2 && (!(in >> comma) || comma != ',')) return std::nullopt;
    rgb[static_cast<size_t>(i)] = static_cast<uint8_t>(v);
  }
  std::string rest;
  if (in >> rest) return std::nullopt;
  return rgb;
}

StatusOr<EncodedImage> ReadPhoto(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return NotFoundError("cannot read " + path);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  EncodedImage image;
  image.bytes = bytes.str();
  // The server decodes by content; the format names what the client believes it is.
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(), ::tolower);
  const bool png = lower.size() > 4 && lower.substr(lower.size() - 4) == ".png";
  image.format = png ? "png" : "jpeg";
  return image;
}

std::string Rgb(const std::array<uint8_t, 3>& c) {
  return std::to_string(c[0]) + "," + std::to_string(c[1]) + "," + std::to_string(c[2]);
}

int ObjectsAdd(CliContext& context, const ArgParser& parser) {
  const std::vector<std::string>& args = parser.positional();
  if (args.size() < 3) {
    return ReportUsage("objects add needs a label and at least one image", kObjectsUsage);
  }
  std::optional<std::array<uint8_t, 3>> colour;
  if (parser.Has("colour")) {
    colour = ParseColour(parser.Get("colour"));
    if (!colour) return ReportUsage("--colour must be R,G,B with values 0..255", kObjectsUsage);
  }
  std::vector<EncodedImage> photos;
  for (size_t i = 2; i < args.size(); ++i) {
    StatusOr<EncodedImage> photo = ReadPhoto(args[i]);
    if (!photo.ok()) return ReportError(photo.status());
    photos.push_back(std::move(photo).value());
  }
  MapClient client = MakeClient(context);
  StatusOr<ObjectType> type = client.RegisterObject(args[1], parser.Get("map"), photos, colour);
  if (!type.ok()) return ReportError(type.status());
  if (context.json) {
    PrintJson({{"object", ToJson(*type)}});
  } else {
    std::cout << "registered '" << type->label << "' ("
              << (type->map_name.empty() ? "global" : "map " + type->map_name) << ", "
              << type->views.size() << " photo" << (type->views.size() == 1 ? "" : "s")
              << ", colour " << Rgb(type->rgb) << ")\n";
  }
  return kExitOk;
}

int ObjectsList(CliContext& context, const ArgParser& parser) {
  if (parser.positional().size() != 1)
    return ReportUsage("objects list takes no arguments", kObjectsUsage);
  MapClient client = MakeClient(context);
  StatusOr<std::vector<ObjectType>> types = client.ListObjectTypes(parser.Get("map"));
  if (!types.ok()) return ReportError(types.status());
  if (context.json) {
    nlohmann::json out = {{"objects", nlohmann::json::array()}};
    for (const ObjectType& t : *types) out["objects"].push_back(ToJson(t));
    PrintJson(out);
    return kExitOk;
  }
  if (types->empty()) std::cout << "no objects registered\n";
  for (const ObjectType& t : *types) {
    std::cout << std::left << std::setw(20) << t.label << " " << std::setw(16)
              << (t.map_name.empty() ? "(global)" : t.map_name) << " photos " << std::setw(3)
              << t.views.size() << " colour " << Rgb(t.rgb) << "\n";
  }
  return kExitOk;
}

int ObjectsRemove(CliContext& context, const ArgParser& parser) {
  if (parser.positional().size() != 2) {
    return ReportUsage("objects remove needs exactly one label", kObjectsUsage);
  }
  MapClient client = MakeClient(context);
  const std::string& label = parser.positional()[1];
  if (Status status = client.RemoveObject(label, parser.Get("map")); !status.ok()) {
    return ReportError(status);
  }
  if (context.json) {
    PrintJson({{"removed", label}});
  } else {
    std::cout << "removed '" << label << "' with its observations and instances\n";
  }
  return kExitOk;
}

void PrintInstances(const std::vector<ObjectInstance>& instances, bool with_distance) {
  for (const ObjectInstance& o : instances) {
    std::cout << std::left << std::setw(16) << o.label << " map " << std::setw(12) << o.map_name
              << std::right << std::fixed << std::setprecision(2) << " at (" << std::setw(6)
              << o.position.x() << ", " << std::setw(6) << o.position.y() << ", " << std::setw(6)
              << o.position.z() << ") m";
    if (with_distance) std::cout << ", " << o.distance_m << " m away";
    std::cout << ", size " << o.extent.x() << " x " << o.extent.y() << " x " << o.extent.z()
              << " m, confidence " << o.confidence << ", seen " << o.observations << " times\n";
    std::cout.unsetf(std::ios::fixed);
    std::cout << std::setprecision(6);
  }
}

}  // namespace

int RunObjects(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("map", "M", "the map the object belongs to (default: global)");
  parser.AddFlag("colour", "R,G,B", "objects add: drawing colour (default: chosen from the label)");
  if (int rc = ParseSubcommand(parser, &context, argc, argv, kObjectsUsage, 1, 1000); rc >= 0) {
    return rc;
  }
  const std::string& verb = parser.positional()[0];
  if (verb == "add") return ObjectsAdd(context, parser);
  if (verb == "list") return ObjectsList(context, parser);
  if (verb == "remove") return ObjectsRemove(context, parser);
  return ReportUsage("unknown objects command '" + verb + "'", kObjectsUsage);
}

int RunWhere(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("map", "M", "only this map (default: every map)");
  if (int rc = ParseSubcommand(parser, &context, argc, argv,
                               "usage: semmap where [LABEL] [--map M] [--json]\n"
                               "  Where the objects of a label (every label without one) are:\n"
                               "  position in the map frame, size, confidence.\n",
                               0, 1);
      rc >= 0) {
    return rc;
  }
  MapClient client = MakeClient(context);
  const std::string label = parser.positional().empty() ? "" : parser.positional()[0];
  StatusOr<std::vector<ObjectInstance>> found = client.FindObjects(label, parser.Get("map"));
  if (!found.ok()) return ReportError(found.status());
  if (context.json) {
    nlohmann::json out = {{"objects", nlohmann::json::array()}};
    for (const ObjectInstance& o : *found) out["objects"].push_back(ToJson(o));
    PrintJson(out);
    return kExitOk;
  }
  if (found->empty())
    std::cout << (label.empty() ? "no objects found" : "no '" + label + "' found") << "\n";
  PrintInstances(*found, false);
  return kExitOk;
}

int RunNear(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("map", "M", "the map whose frame the point is in (default: the only map)");
  parser.AddFlag("label", "L", "only objects of this label");
  const std::string usage =
      "usage: semmap near X Y Z RADIUS [--label L] [--map M] [--json]\n"
      "  Objects within RADIUS metres of the point (map frame), nearest first.\n";
  if (int rc = ParseSubcommand(parser, &context, argc, argv, usage, 4, 4); rc >= 0) return rc;
  double values[4];
  for (int i = 0; i < 4; ++i) {
    const std::string& text = parser.positional()[static_cast<size_t>(i)];
    char* end = nullptr;
    values[i] = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || !std::isfinite(values[i])) {
      return ReportUsage("'" + text + "' is not a number", usage);
    }
  }
  if (values[3] <= 0) return ReportUsage("RADIUS must be > 0", usage);
  MapClient client = MakeClient(context);
  StatusOr<std::vector<ObjectInstance>> found = client.ObjectsNear(
      parser.Get("map"), {values[0], values[1], values[2]}, values[3], parser.Get("label"));
  if (!found.ok()) return ReportError(found.status());
  if (context.json) {
    nlohmann::json out = {{"objects", nlohmann::json::array()}};
    for (const ObjectInstance& o : *found)
      out["objects"].push_back(ToJson(o, /*with_distance=*/true));
    PrintJson(out);
    return kExitOk;
  }
  if (found->empty()) std::cout << "nothing within " << values[3] << " m\n";
  PrintInstances(*found, true);
  return kExitOk;
}

}  // namespace semmap::cli

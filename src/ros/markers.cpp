#include "multiview_object_detection/ros/markers.h"

#include <sensor_msgs/point_cloud2_iterator.h>

#include <cmath>
#include <cstdint>
#include <cstring>

#include "multiview_object_detection/pipeline/types/oriented_box.h"
#include "multiview_object_detection/ros/conversions.h"
#include "multiview_object_detection/ros/label_placement.h"

namespace mvod {
namespace {

// HSV hue -> RGB with full saturation and value 0.9.
std_msgs::ColorRGBA colorFromHue(double hue) {
  hue = hue - std::floor(hue);
  const double h = hue * 6.0;
  const int sector = static_cast<int>(h) % 6;
  const double f = h - std::floor(h);
  const double v = 0.9;
  const double p = v * 0.15;
  const double q = v * (1.0 - 0.85 * f);
  const double t = v * (0.15 + 0.85 * f);
  double r = v, g = t, b = p;
  switch (sector) {
    case 0:
      r = v;
      g = t;
      b = p;
      break;
    case 1:
      r = q;
      g = v;
      b = p;
      break;
    case 2:
      r = p;
      g = v;
      b = t;
      break;
    case 3:
      r = p;
      g = q;
      b = v;
      break;
    case 4:
      r = t;
      g = p;
      b = v;
      break;
    default:
      r = v;
      g = p;
      b = q;
      break;
  }
  std_msgs::ColorRGBA color;
  color.r = static_cast<float>(r);
  color.g = static_cast<float>(g);
  color.b = static_cast<float>(b);
  color.a = 1.f;
  return color;
}

// Golden-ratio hues: neighbouring ids and classes get clearly different colours.
double goldenHue(std::int64_t index) {
  constexpr double kGolden = 0.618033988749895;
  const double hue = 0.12 + kGolden * static_cast<double>(index);
  return hue - std::floor(hue);
}

// Class and id: what tells the objects apart. The probability is in ~objects and ~get_objects;
// over a table of 25 objects it made every label half as long again (issue 56).
std::string labelText(const MapObject& object) {
  return object.class_name + " #" + std::to_string(object.id);
}

constexpr double kLabelHeightM = 0.12;       // text height: legible from 5-10 m in rviz
constexpr double kSmallLabelHeightM = 0.07;  // a small object's: legible as one comes closer
constexpr double kSmallObjectM = 0.5;        // largest side under this: a small object

// Furniture's labels read from across the room; the labels of the books and cups on a table are
// smaller, so they crowd the view less and read as the user zooms in on them.
double labelHeightM(const MapObject& object) {
  return object.box.size_m.maxCoeff() < kSmallObjectM ? kSmallLabelHeightM : kLabelHeightM;
}
constexpr double kDashM = 0.06;  // a completed box's dashes (and gaps)

geometry_msgs::Point toPoint(const Eigen::Vector3d& p) {
  geometry_msgs::Point point;
  point.x = p.x();
  point.y = p.y();
  point.z = p.z();
  return point;
}

// The edge from `a` to `b` into a LINE_LIST: whole, or `dashed` (a completed box: part of it was
// never seen, amodal completion), as dashes kDashM long with gaps as long.
void appendEdge(const Eigen::Vector3d& a, const Eigen::Vector3d& b, bool dashed,
                std::vector<geometry_msgs::Point>* points) {
  const double length_m = (b - a).norm();
  if (!dashed || length_m < 2.0 * kDashM) {
    points->push_back(toPoint(a));
    points->push_back(toPoint(b));
    return;
  }
  const Eigen::Vector3d step = (b - a) / length_m;
  for (double t = 0.0; t < length_m; t += 2.0 * kDashM) {
    points->push_back(toPoint(a + t * step));
    points->push_back(toPoint(a + std::min(t + kDashM, length_m) * step));
  }
}

}  // namespace

std_msgs::ColorRGBA classColor(int class_id) {
  return colorFromHue(goldenHue(static_cast<std::int64_t>(class_id) + 1));
}

std_msgs::ColorRGBA objectColor(int object_id) {
  // Offset from the class palette so an object's points differ from its box colour sequence.
  return colorFromHue(goldenHue(3 * static_cast<std::int64_t>(object_id) + 7));
}

visualization_msgs::MarkerArray objectsToMarkers(const std::vector<MapObject>& objects,
                                                 const std_msgs::Header& header,
                                                 std::set<int>* published_ids) {
  visualization_msgs::MarkerArray array;
  std::set<int> current;
  std::vector<const MapObject*> drawn;
  std::vector<std::string> texts;
  std::vector<double> text_heights_m;
  for (const MapObject& object : objects) {
    if (!object.box.center_m.allFinite() || !object.box.size_m.allFinite()) continue;
    drawn.push_back(&object);
    texts.push_back(labelText(object));
    text_heights_m.push_back(labelHeightM(object));
  }
  const std::vector<LabelPlacement> labels = placeLabels(drawn, texts, text_heights_m);
  for (size_t k = 0; k < drawn.size(); ++k) {
    const MapObject& object = *drawn[k];
    current.insert(object.id);
    visualization_msgs::Marker box;
    box.header = header;
    box.ns = "boxes";
    box.id = object.id;
    box.type = visualization_msgs::Marker::LINE_LIST;
    box.action = visualization_msgs::Marker::ADD;
    box.pose.orientation.w = 1.0;  // points are in the world frame
    box.scale.x = 0.02;            // line width (m)
    box.color = classColor(object.class_id);
    const std::vector<Eigen::Vector3d> corners = object.box.corners();
    // Corner i has sign bits (x: 1, y: 2, z: 4); the edges join corners one bit apart. A completed
    // box is dashed.
    for (int i = 0; i < 8; ++i) {
      for (int bit = 1; bit < 8; bit <<= 1) {
        if (i & bit) continue;
        appendEdge(corners[i], corners[i | bit], object.box_completed, &box.points);
      }
    }
    array.markers.push_back(box);

    visualization_msgs::Marker label;
    label.header = header;
    label.ns = "labels";
    label.id = object.id;
    label.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    label.action = visualization_msgs::Marker::ADD;
    const Eigen::Vector3d& position = labels[k].position_m;
    label.pose.position.x = position.x();
    label.pose.position.y = position.y();
    label.pose.position.z = position.z();
    label.pose.orientation.w = 1.0;
    label.scale.z = text_heights_m[k];
    label.color = classColor(object.class_id);
    label.text = texts[k];
    array.markers.push_back(label);

    // From the box top to the label's foot: which box a label in a column belongs to.
    visualization_msgs::Marker line = box;
    line.ns = "label_lines";
    line.scale.x = 0.008;
    line.points.resize(2);
    const Eigen::Vector3d foot =
        position - (position - labels[k].box_top_m).normalized() * (0.5 * text_heights_m[k]);
    for (const auto& [point, at] : {std::make_pair(&line.points[0], labels[k].box_top_m),
                                    std::make_pair(&line.points[1], foot)}) {
      point->x = at.x();
      point->y = at.y();
      point->z = at.z();
    }
    array.markers.push_back(line);
  }
  if (published_ids != nullptr) {
    for (const int id : *published_ids) {
      if (current.count(id) > 0) continue;
      for (const char* ns : {"boxes", "labels", "label_lines"}) {
        visualization_msgs::Marker erase;
        erase.header = header;
        erase.ns = ns;
        erase.id = id;
        erase.action = visualization_msgs::Marker::DELETE;
        erase.pose.orientation.w = 1.0;
        array.markers.push_back(erase);
      }
    }
    *published_ids = std::move(current);
  }
  return array;
}

void objectsToPointCloud2(const std::vector<MapObject>& objects, const std_msgs::Header& header,
                          sensor_msgs::PointCloud2* cloud) {
  std::vector<const MapObject*> pointers;
  pointers.reserve(objects.size());
  for (const MapObject& object : objects) pointers.push_back(&object);
  objectsToPointCloud2(pointers, header, cloud);
}

void objectsToPointCloud2(const std::vector<const MapObject*>& objects,
                          const std_msgs::Header& header, sensor_msgs::PointCloud2* cloud) {
  size_t total = 0;
  for (const MapObject* object : objects) {
    total += object->segment_W.empty() ? object->points_W.size() : object->segment_W.size();
  }
  cloud->header = header;
  cloud->height = 1;
  cloud->is_dense = true;
  sensor_msgs::PointCloud2Modifier modifier(*cloud);
  modifier.setPointCloud2Fields(
      4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "rgb", 1, sensor_msgs::PointField::FLOAT32);
  modifier.resize(total);
  // An iterator over an empty cloud binds a reference to no data (undefined behaviour).
  if (total == 0) return;
  sensor_msgs::PointCloud2Iterator<float> x(*cloud, "x");
  sensor_msgs::PointCloud2Iterator<float> y(*cloud, "y");
  sensor_msgs::PointCloud2Iterator<float> z(*cloud, "z");
  sensor_msgs::PointCloud2Iterator<float> rgb(*cloud, "rgb");
  size_t written = 0;
  for (const MapObject* object : objects) {
    const std_msgs::ColorRGBA c = objectColor(object->id);
    const uint32_t packed = (static_cast<uint32_t>(c.r * 255.f) << 16) |
                            (static_cast<uint32_t>(c.g * 255.f) << 8) |
                            static_cast<uint32_t>(c.b * 255.f);
    float packed_float = 0.f;
    std::memcpy(&packed_float, &packed, sizeof(float));
    const PointCloud& points = object->segment_W.empty() ? object->points_W : object->segment_W;
    for (const Eigen::Vector3f& p : points) {
      if (!p.allFinite()) continue;
      *x = p.x();
      *y = p.y();
      *z = p.z();
      *rgb = packed_float;
      ++x;
      ++y;
      ++z;
      ++rgb;
      ++written;
    }
  }
  if (written != total) modifier.resize(written);  // non-finite points were skipped
}

}  // namespace mvod

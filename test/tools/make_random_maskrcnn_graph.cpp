// TEST TOOLING, not a user tool: the Mask R-CNN weights are not available on the machines that test
// this package, so the DNN path is proven on a random-weights graph this tool writes
// (test/core/test_maskrcnn_random_weights.cpp).
//
// Writes a TensorFlow frozen graph (GraphDef, binary protobuf) with RANDOM weights for OpenCV's
// text graph of Mask R-CNN Inception v2 COCO (mask_rcnn_inception_v2_coco_2018_01_28.pbtxt), so
// that cv::dnn::readNetFromTensorflow(pb, pbtxt) loads it and a forward pass runs without the real
// 64 MB weights. OpenCV takes the structure from the .pbtxt and looks up, by name, a Const node for
// every input the text graph references but does not define (kernels, biases, batch-norm
// parameters, axis and size constants); this tool writes exactly those Const nodes.
//
// Shapes: channel counts are propagated through the text graph from the 3-channel input; the output
// depths of the convolutions are the Inception v2 (BN-Inception) ones of TensorFlow's
// faster_rcnn_inception_v2 feature extractor, the heads' sizes come from the text graph itself
// (anchors per cell from the PriorBox node, classes from detection_out_final).
//
// The weights mean nothing; this is for testing the code path. One bias is set so that there is
// something to decode: the second stage scores every proposal as the first class (label line 0,
// "person" in COCO) with probability ~0.97, so after the network's own NMS there are detections
// (tens of them, at the random region proposals' places) with random masks.
//
// --depth-multiplier F (default 1: the real model's shapes, a 64 MB file) scales every hidden
// layer's depth as TensorFlow's depth_multiplier does (at least 16 channels), for fast tests: the
// graph, its op types and its outputs' shapes stay the same.
//
// Usage: make_random_maskrcnn_graph --pbtxt FILE --output FILE.pb [--seed N] [--depth-multiplier F]
// Needs only the C++17 standard library (no protobuf library: the wire format is written here).

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

// ---------------------------------------------------------------------------------------------
// Protobuf text format: a generic tree, enough for GraphDef text files.

struct TextMessage;

struct TextField {
  std::string key;
  std::string scalar;                    // unquoted string / number / enum name
  std::shared_ptr<TextMessage> message;  // set for `key { ... }`
};

struct TextMessage {
  std::vector<TextField> fields;

  const TextField* find(const std::string& key) const {
    for (const TextField& f : fields) {
      if (f.key == key) return &f;
    }
    return nullptr;
  }
  std::vector<const TextField*> findAll(const std::string& key) const {
    std::vector<const TextField*> out;
    for (const TextField& f : fields) {
      if (f.key == key) out.push_back(&f);
    }
    return out;
  }
};

class TextParser {
 public:
  explicit TextParser(std::string text) : text_(std::move(text)) {}

  std::shared_ptr<TextMessage> parse() {
    auto root = parseFields(/*nested=*/false);
    return root;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    int line = 1;
    for (size_t i = 0; i < pos_ && i < text_.size(); ++i) line += text_[i] == '\n';
    throw std::runtime_error("text graph, line " + std::to_string(line) + ": " + what);
  }

  void skipSpace() {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (std::isspace(static_cast<unsigned char>(c))) {
        ++pos_;
      } else if (c == '#') {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
      } else {
        break;
      }
    }
  }

  std::string identifier() {
    skipSpace();
    const size_t start = pos_;
    while (pos_ < text_.size() &&
           (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '_' ||
            text_[pos_] == '.' || text_[pos_] == '-' || text_[pos_] == '+')) {
      ++pos_;
    }
    if (start == pos_) fail("expected a name or a value");
    return text_.substr(start, pos_ - start);
  }

  std::string quoted() {
    const char quote = text_[pos_++];
    std::string out;
    while (pos_ < text_.size() && text_[pos_] != quote) {
      char c = text_[pos_++];
      if (c == '\\' && pos_ < text_.size()) {
        const char e = text_[pos_++];
        switch (e) {
          case 'n':
            c = '\n';
            break;
          case 't':
            c = '\t';
            break;
          default:
            c = e;
            break;
        }
      }
      out.push_back(c);
    }
    if (pos_ >= text_.size()) fail("unterminated string");
    ++pos_;
    return out;
  }

  std::shared_ptr<TextMessage> parseFields(bool nested) {
    auto message = std::make_shared<TextMessage>();
    while (true) {
      skipSpace();
      if (pos_ >= text_.size()) {
        if (nested) fail("missing '}'");
        return message;
      }
      if (text_[pos_] == '}') {
        if (!nested) fail("unexpected '}'");
        ++pos_;
        return message;
      }
      TextField field;
      field.key = identifier();
      skipSpace();
      if (pos_ < text_.size() && text_[pos_] == ':') {
        ++pos_;
        skipSpace();
      }
      if (pos_ >= text_.size()) fail("missing value for '" + field.key + "'");
      if (text_[pos_] == '{' || text_[pos_] == '<') {
        ++pos_;
        field.message = parseFields(/*nested=*/true);
      } else if (text_[pos_] == '"' || text_[pos_] == '\'') {
        field.scalar = quoted();
      } else {
        field.scalar = identifier();
      }
      message->fields.push_back(std::move(field));
    }
  }

  std::string text_;
  size_t pos_ = 0;
};

// ---------------------------------------------------------------------------------------------
// The text graph's nodes.

struct Node {
  std::string name;
  std::string op;
  std::vector<std::string> inputs;
  std::shared_ptr<TextMessage> raw;

  // attr { key: K value { ... } } -> the value message, or nullptr.
  const TextMessage* attr(const std::string& key) const {
    for (const TextField* a : raw->findAll("attr")) {
      const TextField* k = a->message ? a->message->find("key") : nullptr;
      const TextField* v = a->message ? a->message->find("value") : nullptr;
      if (k != nullptr && k->scalar == key && v != nullptr && v->message) return v->message.get();
    }
    return nullptr;
  }
};

std::string nodeNameOf(const std::string& input) {
  std::string name = input;
  if (!name.empty() && name[0] == '^') name.erase(0, 1);
  const size_t colon = name.rfind(':');
  if (colon != std::string::npos) name.erase(colon);
  return name;
}

// ---------------------------------------------------------------------------------------------
// Protobuf wire format.

enum DataType { kDtFloat = 1, kDtInt32 = 3 };

void putVarint(std::string* out, uint64_t value) {
  while (value >= 0x80) {
    out->push_back(static_cast<char>((value & 0x7f) | 0x80));
    value >>= 7;
  }
  out->push_back(static_cast<char>(value));
}

void putTag(std::string* out, int field, int wire_type) {
  putVarint(out, (static_cast<uint64_t>(field) << 3) | static_cast<uint64_t>(wire_type));
}

void putBytes(std::string* out, int field, const std::string& bytes) {
  putTag(out, field, 2);
  putVarint(out, bytes.size());
  out->append(bytes);
}

void putInt(std::string* out, int field, int64_t value) {
  putTag(out, field, 0);
  putVarint(out, static_cast<uint64_t>(value));  // negative: 10-byte two's complement, as protobuf
}

struct Tensor {
  DataType dtype = kDtFloat;
  std::vector<int64_t> shape;  // empty = scalar
  std::vector<float> floats;
  std::vector<int32_t> ints;
};

// TensorProto{dtype=1, tensor_shape=2, tensor_content=4, int_val=7}. Floats go in tensor_content
// (OpenCV's batch-norm import needs it), int32 values in int_val (OpenCV's ConcatV2 import reads
// the axis from there).
std::string encodeTensor(const Tensor& tensor) {
  std::string shape;
  for (int64_t d : tensor.shape) {
    std::string dim;
    putInt(&dim, 1, d);
    putBytes(&shape, 2, dim);
  }
  std::string out;
  putInt(&out, 1, tensor.dtype);
  putBytes(&out, 2, shape);  // present even for a scalar: OpenCV requires has_tensor_shape()
  if (tensor.dtype == kDtFloat) {
    std::string content(tensor.floats.size() * sizeof(float), '\0');
    for (size_t i = 0; i < tensor.floats.size(); ++i) {
      uint32_t bits;
      std::memcpy(&bits, &tensor.floats[i], sizeof(bits));
      for (int b = 0; b < 4; ++b) content[4 * i + b] = static_cast<char>((bits >> (8 * b)) & 0xff);
    }
    putBytes(&out, 4, content);
  } else {
    std::string packed;
    for (int32_t v : tensor.ints)
      putVarint(&packed, static_cast<uint64_t>(static_cast<int64_t>(v)));
    putBytes(&out, 7, packed);
  }
  return out;
}

// NodeDef{name=1, op=2, attr=5 (map entry {key=1, value=2})} with AttrValue{type=6, tensor=8}.
std::string encodeConstNode(const std::string& name, const Tensor& tensor) {
  std::string node;
  putBytes(&node, 1, name);
  putBytes(&node, 2, "Const");
  {
    std::string value;
    putInt(&value, 6, tensor.dtype);
    std::string entry;
    putBytes(&entry, 1, "dtype");
    putBytes(&entry, 2, value);
    putBytes(&node, 5, entry);
  }
  {
    std::string value;
    putBytes(&value, 8, encodeTensor(tensor));
    std::string entry;
    putBytes(&entry, 1, "value");
    putBytes(&entry, 2, value);
    putBytes(&node, 5, entry);
  }
  return node;
}

// ---------------------------------------------------------------------------------------------
// What the model looks like.

// Output depths of TensorFlow's faster_rcnn_inception_v2 feature extractor (slim Inception v2,
// depth_multiplier 1), by the part of the weight name after "InceptionV2/".
const std::map<std::string, int>& inceptionV2Depths() {
  static const std::map<std::string, int> depths = [] {
    std::map<std::string, int> d;
    d["Conv2d_1a_7x7"] = 64;
    d["Conv2d_2b_1x1"] = 64;
    d["Conv2d_2c_3x3"] = 192;
    // {block, b0, b1a, b1b, b2a, b2b, b2c, b3}
    struct Mixed {
      const char* block;
      int b0, b1a, b1b, b2a, b2b, b2c, b3;
    };
    const Mixed mixed[] = {
        {"Mixed_3b", 64, 64, 64, 64, 96, 96, 32},
        {"Mixed_3c", 64, 64, 96, 64, 96, 96, 64},
        {"Mixed_4b", 224, 64, 96, 96, 128, 128, 128},
        {"Mixed_4c", 192, 96, 128, 96, 128, 128, 128},
        {"Mixed_4d", 160, 128, 160, 128, 160, 160, 96},
        {"Mixed_4e", 96, 128, 192, 160, 192, 192, 96},
        {"Mixed_5b", 352, 192, 320, 160, 224, 224, 128},
        {"Mixed_5c", 352, 192, 320, 192, 224, 224, 128},
    };
    for (const Mixed& m : mixed) {
      const std::string b = m.block;
      d[b + "/Branch_0/Conv2d_0a_1x1"] = m.b0;
      d[b + "/Branch_1/Conv2d_0a_1x1"] = m.b1a;
      d[b + "/Branch_1/Conv2d_0b_3x3"] = m.b1b;
      d[b + "/Branch_2/Conv2d_0a_1x1"] = m.b2a;
      d[b + "/Branch_2/Conv2d_0b_3x3"] = m.b2b;
      d[b + "/Branch_2/Conv2d_0c_3x3"] = m.b2c;
      d[b + "/Branch_3/Conv2d_0b_1x1"] = m.b3;
    }
    // Grid-reduction blocks (the third branch is a max pool).
    d["Mixed_4a/Branch_0/Conv2d_0a_1x1"] = 128;
    d["Mixed_4a/Branch_0/Conv2d_1a_3x3"] = 160;
    d["Mixed_4a/Branch_1/Conv2d_0a_1x1"] = 64;
    d["Mixed_4a/Branch_1/Conv2d_0b_3x3"] = 96;
    d["Mixed_4a/Branch_1/Conv2d_1a_3x3"] = 96;
    d["Mixed_5a/Branch_0/Conv2d_0a_1x1"] = 128;
    d["Mixed_5a/Branch_0/Conv2d_1a_3x3"] = 192;
    d["Mixed_5a/Branch_1/Conv2d_0a_1x1"] = 192;
    d["Mixed_5a/Branch_1/Conv2d_0b_3x3"] = 256;
    d["Mixed_5a/Branch_1/Conv2d_1a_3x3"] = 256;
    return d;
  }();
  return depths;
}

constexpr int kStemDepthMultiplier = 8;  // Conv2d_1a_7x7 is separable: min(64 / 3, 8)
constexpr int kRpnDepth = 512;           // first-stage box predictor's shared 3x3 conv
constexpr int kMaskConvDepth = 256;      // 2^int((log2(1024) + log2(90)) / 2)
constexpr int kMinDepth = 16;            // min_depth of the feature extractor
constexpr int kCropSize = 14;            // initial_crop_size of the model's config
constexpr int kMaskSize = 15;            // mask_height / mask_width of the model's config

struct ModelFacts {
  int anchors_per_cell = 0;  // PriorBox widths
  int num_classes = 0;       // detection_out_final num_classes (COCO: 90)
};

class GraphShapes {
 public:
  GraphShapes(const std::vector<Node>& nodes, double depth_multiplier)
      : nodes_(nodes), depth_multiplier_(depth_multiplier) {
    for (size_t i = 0; i < nodes_.size(); ++i) index_[nodes_[i].name] = i;
    for (const Node& n : nodes_) {
      if (n.op == "PriorBox") {
        const TextMessage* width = n.attr("width");
        const TextField* tensor = width ? width->find("tensor") : nullptr;
        if (tensor && tensor->message) {
          facts_.anchors_per_cell = static_cast<int>(tensor->message->findAll("float_val").size());
        }
      }
      if (n.op == "DetectionOutput" && n.name == "detection_out_final") {
        const TextMessage* classes = n.attr("num_classes");
        const TextField* i = classes ? classes->find("i") : nullptr;
        if (i) facts_.num_classes = std::atoi(i->scalar.c_str());
      }
    }
    if (facts_.anchors_per_cell <= 0) {
      throw std::runtime_error(
          "no PriorBox node with a 'width' list: not a Faster/Mask R-CNN graph");
    }
    if (facts_.num_classes <= 0) {
      throw std::runtime_error(
          "no detection_out_final node with num_classes: not a Mask R-CNN graph");
    }
  }

  const ModelFacts& facts() const { return facts_; }
  bool defined(const std::string& name) const { return index_.count(name) > 0; }

  // Channels (last NHWC dimension, or the feature size of a 2-D tensor) of a node's output.
  int channels(const std::string& input) {
    const std::string name = nodeNameOf(input);
    auto cached = channels_.find(name);
    if (cached != channels_.end()) return cached->second;
    auto it = index_.find(name);
    if (it == index_.end()) throw std::runtime_error("no node '" + name + "' in the text graph");
    if (visiting_.count(name))
      throw std::runtime_error("cycle in the text graph at '" + name + "'");
    visiting_.insert(name);
    const Node& n = nodes_[it->second];
    int c = 0;
    if (n.op == "Placeholder") {
      c = placeholderChannels(n);
    } else if (n.op == "Conv2D" || n.op == "MatMul") {
      c = outputDepth(n.op, n.inputs.at(1));
    } else if (n.op == "DepthwiseConv2dNative") {
      c = channels(n.inputs.at(0)) * kStemDepthMultiplier;
    } else if (n.op == "ConcatV2") {
      for (size_t i = 0; i + 1 < n.inputs.size(); ++i) c += channels(n.inputs[i]);
    } else if (!n.inputs.empty()) {
      c = channels(n.inputs[0]);  // elementwise, pooling, resize, crop, batch norm, ...
    } else {
      throw std::runtime_error("cannot tell the channels of '" + name + "' (" + n.op + ")");
    }
    visiting_.erase(name);
    channels_[name] = c;
    return c;
  }

  // Output depth of the layer whose weights are `weights_name`.
  int outputDepth(const std::string& op, const std::string& weights_name) const {
    const std::string w = nodeNameOf(weights_name);
    const size_t at = w.find("InceptionV2/");
    if (at != std::string::npos) {
      std::string key = w.substr(at + std::string("InceptionV2/").size());
      const size_t slash = key.rfind('/');
      if (slash != std::string::npos) key.erase(slash);  // drop ".../weights"
      const auto& depths = inceptionV2Depths();
      auto d = depths.find(key);
      if (d == depths.end()) {
        throw std::runtime_error("'" + w + "': layer '" + key +
                                 "' is not an Inception v2 layer this tool knows");
      }
      return scaled(d->second);
    }
    const int anchors = facts_.anchors_per_cell;
    const int classes = facts_.num_classes;
    if (w == "Conv/weights") return scaled(kRpnDepth);
    if (w == "FirstStageBoxPredictor/BoxEncodingPredictor/weights") return 4 * anchors;
    if (w == "FirstStageBoxPredictor/ClassPredictor/weights") return 2 * anchors;
    if (w == "SecondStageBoxPredictor/BoxEncodingPredictor/weights") return 4 * classes;
    if (w == "SecondStageBoxPredictor/ClassPredictor/weights") return classes + 1;
    if (w == "SecondStageBoxPredictor/Conv/weights") return scaled(kMaskConvDepth);
    if (w == "SecondStageBoxPredictor/Conv_1/weights") return classes;
    throw std::runtime_error("unknown " + op + " weights '" + w + "'");
  }

 private:
  int scaled(int depth) const {
    return std::max(static_cast<int>(depth * depth_multiplier_), std::min(depth, kMinDepth));
  }

  int placeholderChannels(const Node& n) const {
    const TextMessage* shape = n.attr("shape");
    const TextField* s = shape ? shape->find("shape") : nullptr;
    if (s && s->message) {
      auto dims = s->message->findAll("dim");
      if (!dims.empty() && dims.back()->message) {
        const TextField* size = dims.back()->message->find("size");
        if (size && std::atoi(size->scalar.c_str()) > 0) return std::atoi(size->scalar.c_str());
      }
    }
    return 3;
  }

  const std::vector<Node>& nodes_;
  std::map<std::string, size_t> index_;
  std::map<std::string, int> channels_;
  std::set<std::string> visiting_;
  double depth_multiplier_ = 1.0;
  ModelFacts facts_;
};

// Kernel height/width from a layer name such as "Conv2d_0b_3x3"; the heads' convolutions (no size
// in the name) are 1x1 for the RPN predictors and 3x3 otherwise, as in the TF model.
std::pair<int, int> kernelSize(const std::string& weights_name) {
  static const std::regex size_in_name("_([0-9]+)x([0-9]+)/");
  std::smatch m;
  if (std::regex_search(weights_name, m, size_in_name)) {
    return {std::stoi(m[1]), std::stoi(m[2])};
  }
  if (weights_name.rfind("FirstStageBoxPredictor/", 0) == 0) return {1, 1};
  return {3, 3};
}

// ---------------------------------------------------------------------------------------------
// Random weights.

class WeightMaker {
 public:
  explicit WeightMaker(uint32_t seed) : rng_(seed) {}

  Tensor normal(std::vector<int64_t> shape, float mean, float stddev) {
    Tensor t;
    t.shape = std::move(shape);
    int64_t count = 1;
    for (int64_t d : t.shape) count *= d;
    std::normal_distribution<float> dist(mean, stddev);
    t.floats.resize(static_cast<size_t>(count));
    for (float& v : t.floats) v = dist(rng_);
    return t;
  }

  static Tensor constant(std::vector<int64_t> shape, float value) {
    Tensor t;
    t.shape = std::move(shape);
    int64_t count = 1;
    for (int64_t d : t.shape) count *= d;
    t.floats.assign(static_cast<size_t>(count), value);
    return t;
  }

  static Tensor ints(std::vector<int32_t> values, bool scalar = false) {
    Tensor t;
    t.dtype = kDtInt32;
    if (!scalar) t.shape = {static_cast<int64_t>(values.size())};
    t.ints = std::move(values);
    return t;
  }

  // He initialisation keeps activations at a steady scale through conv + BN + ReLU stacks; the
  // predictors get small weights so their biases decide the outputs.
  Tensor kernel(const std::string& name, std::vector<int64_t> shape) {
    int64_t fan_in = 1;
    for (size_t i = 0; i + 1 < shape.size(); ++i) fan_in *= shape[i];
    const bool predictor = name.find("BoxEncodingPredictor") != std::string::npos ||
                           name.find("ClassPredictor") != std::string::npos;
    const float stddev = predictor ? 0.01f : std::sqrt(2.f / static_cast<float>(fan_in));
    return normal(std::move(shape), 0.f, stddev);
  }

  Tensor bias(const std::string& name, int64_t size) {
    Tensor t = constant({size}, 0.f);
    if (name == "SecondStageBoxPredictor/ClassPredictor/biases") {
      // Index 0 is the background; index 1 the first label ("person"): softmax ~0.97.
      if (size > 1) t.floats[1] = 8.f;
    }
    return t;
  }

  Tensor batchNorm(const std::string& role, int64_t size) {
    if (role == "gamma") return normal({size}, 1.f, 0.1f);
    if (role == "beta") return normal({size}, 0.f, 0.1f);
    if (role == "moving_mean") return normal({size}, 0.f, 0.1f);
    Tensor var = normal({size}, 0.f, 0.1f);  // moving_variance: positive
    for (float& v : var.floats) v = 1.f + std::fabs(v);
    return var;
  }

 private:
  std::mt19937 rng_;
};

// The Const a node's input `input_index` needs, from the consumer's op and the graph's shapes.
Tensor makeConst(const Node& consumer, size_t input_index, const std::string& const_name,
                 GraphShapes* shapes, WeightMaker* maker) {
  const std::string& op = consumer.op;
  const auto in_channels = [&]() -> int64_t { return shapes->channels(consumer.inputs.at(0)); };
  if (op == "Conv2D" && input_index == 1) {
    const auto [kh, kw] = kernelSize(const_name);
    return maker->kernel(const_name, {kh, kw, in_channels(), shapes->outputDepth(op, const_name)});
  }
  if (op == "DepthwiseConv2dNative" && input_index == 1) {
    const auto [kh, kw] = kernelSize(const_name);
    return maker->kernel(const_name, {kh, kw, in_channels(), kStemDepthMultiplier});
  }
  if (op == "MatMul" && input_index == 1) {
    return maker->kernel(const_name, {in_channels(), shapes->outputDepth(op, const_name)});
  }
  if (op == "BiasAdd" && input_index == 1) return maker->bias(const_name, in_channels());
  if ((op == "FusedBatchNorm" || op == "FusedBatchNormV3") && input_index >= 1 &&
      input_index <= 4) {
    static const char* roles[] = {"", "gamma", "beta", "moving_mean", "moving_variance"};
    return maker->batchNorm(roles[input_index], in_channels());
  }
  if (op == "ConcatV2" && input_index + 1 == consumer.inputs.size()) {
    return WeightMaker::ints({3}, /*scalar=*/true);  // NHWC channels
  }
  if (op == "Mul" && const_name == "Preprocessor/mul/x") {
    return WeightMaker::constant({}, 2.f / 255.f);  // Inception preprocessing: 2 x / 255 - 1
  }
  if (op == "Sub" && const_name == "Preprocessor/sub/y") return WeightMaker::constant({}, 1.f);
  if (op == "CropAndResize" && input_index == 2) return WeightMaker::ints({kCropSize, kCropSize});
  if (op == "Mean" && input_index == 1) return WeightMaker::ints({1, 2});  // global H, W average
  if (op == "ResizeBilinear" && input_index == 1) return WeightMaker::ints({kMaskSize, kMaskSize});
  if (op == "Transpose" && input_index == 1) return WeightMaker::ints({0, 3, 1, 2});  // NHWC->NCHW
  if (op == "Reshape" && input_index == 1) {
    // Class logits [boxes, classes + 1] -> [boxes, 1, classes + 1] for the softmax.
    return WeightMaker::ints({-1, 1, static_cast<int32_t>(in_channels())});
  }
  throw std::runtime_error("do not know what constant '" + const_name + "' (input " +
                           std::to_string(input_index) + " of " + op + " node '" + consumer.name +
                           "') should hold");
}

struct Options {
  std::string pbtxt;
  std::string output;
  uint32_t seed = 0;
  double depth_multiplier = 1.0;
};

void printUsage() {
  std::cerr << "usage: make_random_maskrcnn_graph --pbtxt FILE --output FILE.pb [--seed N]\n"
               "                                  [--depth-multiplier F]\n"
               "Writes a frozen graph with random weights for OpenCV's Mask R-CNN Inception v2\n"
               "text graph (mask_rcnn_inception_v2_coco_2018_01_28.pbtxt), for tests only.\n";
}

bool parseOptions(int argc, char** argv, Options* options, std::string* error) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      *error = "";
      return false;
    }
    if (i + 1 >= argc) {
      *error = "option " + arg + " needs a value";
      return false;
    }
    const std::string value = argv[++i];
    if (arg == "--pbtxt") {
      options->pbtxt = value;
    } else if (arg == "--output") {
      options->output = value;
    } else if (arg == "--depth-multiplier") {
      char* end = nullptr;
      const double multiplier = std::strtod(value.c_str(), &end);
      if (end == value.c_str() || *end != '\0' || !(multiplier > 0.0 && multiplier <= 1.0)) {
        *error = "--depth-multiplier needs a number in (0, 1], got '" + value + "'";
        return false;
      }
      options->depth_multiplier = multiplier;
    } else if (arg == "--seed") {
      char* end = nullptr;
      const unsigned long seed = std::strtoul(value.c_str(), &end, 10);
      if (end == value.c_str() || *end != '\0') {
        *error = "--seed needs a non-negative integer, got '" + value + "'";
        return false;
      }
      options->seed = static_cast<uint32_t>(seed);
    } else {
      *error = "unknown option " + arg;
      return false;
    }
  }
  if (options->pbtxt.empty() || options->output.empty()) {
    *error = "--pbtxt and --output are required";
    return false;
  }
  return true;
}

int run(const Options& options) {
  std::ifstream in(options.pbtxt);
  if (!in) throw std::runtime_error("cannot read text graph '" + options.pbtxt + "'");
  std::stringstream text;
  text << in.rdbuf();
  const std::shared_ptr<TextMessage> graph = TextParser(text.str()).parse();

  std::vector<Node> nodes;
  for (const TextField* f : graph->findAll("node")) {
    if (!f->message) throw std::runtime_error("'node' without a body in the text graph");
    Node n;
    n.raw = f->message;
    const TextField* name = f->message->find("name");
    const TextField* op = f->message->find("op");
    if (!name || !op) throw std::runtime_error("a node of the text graph has no name or op");
    n.name = name->scalar;
    n.op = op->scalar;
    for (const TextField* input : f->message->findAll("input")) n.inputs.push_back(input->scalar);
    nodes.push_back(std::move(n));
  }
  if (nodes.empty()) throw std::runtime_error("'" + options.pbtxt + "' holds no nodes");

  GraphShapes shapes(nodes, options.depth_multiplier);
  WeightMaker maker(options.seed);

  // Written under a temporary name and renamed at the end: a failure leaves no partial graph.
  const std::string partial = options.output + ".partial";
  std::ofstream out(partial, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("cannot write '" + partial + "'");
  struct RemoveOnFailure {
    const std::string& path;
    bool done = false;
    ~RemoveOnFailure() {
      if (!done) std::remove(path.c_str());
    }
  } cleanup{partial};
  std::set<std::string> written;
  std::map<std::string, std::vector<int64_t>> written_shapes;
  size_t floats = 0;
  for (const Node& consumer : nodes) {
    for (size_t i = 0; i < consumer.inputs.size(); ++i) {
      const std::string& input = consumer.inputs[i];
      if (input.empty() || input[0] == '^') continue;  // control dependency
      const std::string name = nodeNameOf(input);
      if (shapes.defined(name)) continue;
      const Tensor tensor = makeConst(consumer, i, name, &shapes, &maker);
      if (written.count(name)) {
        // Shared weights (the second stage runs twice on the same variables): one Const.
        if (written_shapes[name] != tensor.shape) {
          throw std::runtime_error("'" + name + "' is used with two different shapes");
        }
        continue;
      }
      std::string record;
      putBytes(&record, 1, encodeConstNode(name, tensor));  // GraphDef.node
      out.write(record.data(), static_cast<std::streamsize>(record.size()));
      written.insert(name);
      written_shapes[name] = tensor.shape;
      floats += tensor.floats.size();
    }
  }
  out.close();
  if (!out) throw std::runtime_error("error writing '" + partial + "'");
  if (std::rename(partial.c_str(), options.output.c_str()) != 0) {
    throw std::runtime_error("cannot rename '" + partial + "' to '" + options.output + "'");
  }
  cleanup.done = true;
  std::cout << "wrote " << written.size() << " constants (" << floats << " random weights) to "
            << options.output << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  std::string error;
  if (!parseOptions(argc, argv, &options, &error)) {
    if (!error.empty()) std::cerr << "make_random_maskrcnn_graph: " << error << "\n";
    printUsage();
    return error.empty() ? 0 : 2;
  }
  try {
    return run(options);
  } catch (const std::exception& e) {
    std::cerr << "make_random_maskrcnn_graph: " << e.what() << "\n";
    return 1;
  }
}

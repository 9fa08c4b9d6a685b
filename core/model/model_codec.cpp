#include "core/model/model_codec.hpp"

#include <cmath>
#include <cstring>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/common/checksum.hpp"
#include "core/model/model_cache.hpp"

namespace soilvol::model {
namespace {

constexpr char kMagic[8] = {'S', 'O', 'I', 'L', 'V', 'O', 'L', 'M'};
constexpr std::size_t kHeaderBytes = sizeof(kMagic) + 4 + 4 + 8;
constexpr std::size_t kMaxPolygonVertices = 1024;
constexpr uint32_t kMaxEmptyScans = 64;

// Little-endian writer (the machines we target are little-endian; the layout is fixed anyway).
class Writer {
  public:
    template <typename T>
    void Put(T value) {
        char raw[sizeof(T)];
        std::memcpy(raw, &value, sizeof(T));
        out_.append(raw, sizeof(T));
    }
    void PutCloud(const Cloud& cloud) {
        Put<uint64_t>(cloud.size());
        for (const Eigen::Vector3f& p : cloud) {
            for (int i = 0; i < 3; ++i) Put<float>(p[i]);
        }
    }
    void PutFloats(const std::vector<float>& values) {
        Put<uint64_t>(values.size());
        for (const float v : values) Put<float>(v);
    }
    std::string Take() { return std::move(out_); }

  private:
    std::string out_;
};

// Bounds-checked reader; every failure is sticky and reported once at the end.
class Reader {
  public:
    explicit Reader(std::string_view bytes) : bytes_(bytes) {}

    template <typename T>
    T Get() {
        T value{};
        if (!Has(sizeof(T))) return value;
        std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
        pos_ += sizeof(T);
        return value;
    }
    double GetFinite(const char* field) {
        const double value = Get<double>();
        if (!std::isfinite(value)) Fail(absl::StrCat(field, " is not finite"));
        return value;
    }
    Cloud GetCloud(const char* field) {
        const uint64_t count = Get<uint64_t>();
        if (!ok() || count > Remaining() / (3 * sizeof(float))) {
            Fail(absl::StrCat(field, ": point count ", count, " exceeds the payload"));
            return {};
        }
        Cloud cloud(count);
        for (Eigen::Vector3f& p : cloud) {
            for (int i = 0; i < 3; ++i) p[i] = Get<float>();
            if (!p.allFinite()) Fail(absl::StrCat(field, " has a non-finite point"));
        }
        return cloud;
    }
    std::vector<float> GetFloats(const char* field) {
        const uint64_t count = Get<uint64_t>();
        if (!ok() || count > Remaining() / sizeof(float)) {
            Fail(absl::StrCat(field, ": count ", count, " exceeds the payload"));
            return {};
        }
        std::vector<float> values(count);
        for (float& v : values) {
            v = Get<float>();
            if (!std::isfinite(v)) Fail(absl::StrCat(field, " has a non-finite value"));
        }
        return values;
    }
    bool Has(std::size_t n) {
        if (ok() && Remaining() >= n) return true;
        Fail("payload is truncated");
        return false;
    }
    std::size_t Remaining() const { return bytes_.size() - pos_; }
    void Fail(std::string message) {
        if (error_.empty()) error_ = std::move(message);
    }
    bool ok() const { return error_.empty(); }
    const std::string& error() const { return error_; }

  private:
    std::string_view bytes_;
    std::size_t pos_ = 0;
    std::string error_;
};

void PutPose(Writer& w, const Pose& pose) {
    for (int i = 0; i < 16; ++i) w.Put<double>(pose.matrix().data()[i]);
}

Pose GetPose(Reader& r) {
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) m.data()[i] = r.GetFinite("pose");
    const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
    if ((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
        rotation.determinant() < 0.0 || m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
        r.Fail("pose is not a rigid transform");
    }
    Pose pose = Pose::Identity();
    pose.matrix() = m;
    return pose;
}

std::string EncodePayload(const ContainerModel& model) {
    Writer w;
    PutPose(w, model.opening.T_scan_container);
    const auto& vertices = model.opening.polygon.Vertices();
    w.Put<uint32_t>(static_cast<uint32_t>(vertices.size()));
    for (const Eigen::Vector2d& v : vertices) {
        w.Put<double>(v.x());
        w.Put<double>(v.y());
    }
    w.Put<double>(model.opening.nonplanarity_m);
    w.Put<double>(model.opening.area_m2);
    for (const Cloud* cloud :
         {&model.inside, &model.structure, &model.alignment_points, &model.alignment_normals}) {
        w.PutCloud(*cloud);
    }
    w.Put<uint32_t>(static_cast<uint32_t>(model.cavity.size()));
    for (const WeightedCloud& c : model.cavity) {
        w.PutCloud(c.points);
        w.PutFloats(c.weights);
        for (int i = 0; i < 3; ++i) w.Put<double>(c.sensor[i]);
    }
    w.Put<uint32_t>(static_cast<uint32_t>(model.walls.size()));
    for (const WallPrior& wall : model.walls) {
        w.Put<int32_t>(wall.edge);
        w.Put<double>(wall.thickness_m);
        w.Put<double>(wall.thickness_sigma_m);
        w.Put<uint64_t>(wall.support);
        w.Put<uint32_t>(static_cast<uint32_t>(wall.profile.size()));
        for (const Eigen::Vector2d& p : wall.profile) {
            w.Put<double>(p.x());
            w.Put<double>(p.y());
        }
    }
    for (const int c : model.opening.corner_of_vertex) w.Put<int32_t>(c);
    w.Put<double>(model.struck_capacity_sigma_m3);
    w.Put<uint32_t>(static_cast<uint32_t>(model.unseen.size()));
    for (const UnseenSide& side : model.unseen) {
        w.Put<int32_t>(side.from_corner);
        w.Put<int32_t>(side.to_corner);
        w.Put<double>(side.area_m2);
        w.Put<double>(side.sigma_m3);
    }
    w.Put<uint64_t>(model.mesh.vertices.size());
    for (const Eigen::Vector3d& v : model.mesh.vertices) {
        for (int i = 0; i < 3; ++i) w.Put<double>(v[i]);
    }
    w.Put<uint64_t>(model.mesh.triangles.size());
    for (const Eigen::Vector3i& t : model.mesh.triangles) {
        for (int i = 0; i < 3; ++i) w.Put<int32_t>(t[i]);
    }
    for (const double value :
         {model.structure_radius_m, model.smoothing_radius_m, model.column_top_m,
          model.observed_share, model.depth_m, model.struck_capacity_m3,
          model.heaped_capacity_sae_m3, model.heaped_capacity_iso_m3, model.noise_sigma_m}) {
        w.Put<double>(value);
    }
    w.Put<uint64_t>(model.scan_points);
    w.Put<uint64_t>(model.outside_points);
    return w.Take();
}

absl::StatusOr<ContainerModel> DecodePayload(std::string_view payload, uint32_t version) {
    Reader r(payload);
    ContainerModel model;
    model.opening.T_scan_container = GetPose(r);
    const uint32_t count = r.Get<uint32_t>();
    if (count < 3 || count > kMaxPolygonVertices) r.Fail("opening polygon vertex count is invalid");
    std::vector<Eigen::Vector2d> vertices;
    for (uint32_t i = 0; r.ok() && i < count; ++i) {
        const double x = r.GetFinite("opening polygon");
        vertices.emplace_back(x, r.GetFinite("opening polygon"));
    }
    model.opening.polygon = Polygon2d(std::move(vertices));
    model.opening.nonplanarity_m = r.GetFinite("opening nonplanarity");
    model.opening.area_m2 = r.GetFinite("opening area");
    model.inside = r.GetCloud("inside");
    model.structure = r.GetCloud("structure");
    model.alignment_points = r.GetCloud("alignment points");
    model.alignment_normals = r.GetCloud("alignment normals");
    if (model.alignment_points.size() != model.alignment_normals.size()) {
        r.Fail("alignment points and normals differ in count");
    }
    const uint32_t scans = r.Get<uint32_t>();
    if (scans < 1 || scans > kMaxEmptyScans) r.Fail("empty scan count is invalid");
    for (uint32_t j = 0; r.ok() && j < scans; ++j) {
        WeightedCloud c;
        c.points = r.GetCloud("cavity");
        c.weights = r.GetFloats("cavity weights");
        if (c.weights.size() != c.points.size())
            r.Fail("cavity points and weights differ in count");
        for (int i = 0; i < 3; ++i) c.sensor[i] = r.GetFinite("cavity sensor");
        model.cavity.push_back(std::move(c));
    }
    // Version 2 had no thin-shell prior.
    const uint32_t walls = version >= 3 ? r.Get<uint32_t>() : 0;
    if (walls > kMaxPolygonVertices) r.Fail("wall count is invalid");
    for (uint32_t j = 0; r.ok() && j < walls; ++j) {
        WallPrior wall;
        wall.edge = r.Get<int32_t>();
        if (wall.edge < 0 ||
            static_cast<std::size_t>(wall.edge) >= model.opening.polygon.Vertices().size())
            r.Fail("wall edge is out of range");
        wall.thickness_m = r.GetFinite("wall thickness");
        wall.thickness_sigma_m = r.GetFinite("wall thickness sigma");
        wall.support = r.Get<uint64_t>();
        const uint32_t points = r.Get<uint32_t>();
        if (!r.ok() || points > r.Remaining() / (2 * sizeof(double))) {
            r.Fail("wall profile count exceeds the payload");
            break;
        }
        for (uint32_t i = 0; r.ok() && i < points; ++i) {
            const double z = r.GetFinite("wall profile");
            wall.profile.emplace_back(z, r.GetFinite("wall profile"));
        }
        model.walls.push_back(std::move(wall));
    }
    if (version >= 3) {
        for (int& c : model.opening.corner_of_vertex) {
            c = r.Get<int32_t>();
            if (c < 0 || c > 3) r.Fail("opening corner index is out of range");
        }
        model.struck_capacity_sigma_m3 = r.GetFinite("struck capacity sigma");
        const uint32_t unseen = r.Get<uint32_t>();
        if (unseen > kMaxPolygonVertices) r.Fail("unseen side count is invalid");
        for (uint32_t i = 0; r.ok() && i < unseen; ++i) {
            UnseenSide side;
            side.from_corner = r.Get<int32_t>();
            side.to_corner = r.Get<int32_t>();
            if (side.from_corner < 0 || side.from_corner > 3 || side.to_corner < 0 ||
                side.to_corner > 3) {
                r.Fail("unseen side corner is out of range");
            }
            side.area_m2 = r.GetFinite("unseen area");
            side.sigma_m3 = r.GetFinite("unseen sigma");
            model.unseen.push_back(side);
        }
        const uint64_t mesh_vertices = r.Get<uint64_t>();
        if (!r.ok() || mesh_vertices > r.Remaining() / (3 * sizeof(double))) {
            r.Fail("mesh vertex count exceeds the payload");
        }
        for (uint64_t i = 0; r.ok() && i < mesh_vertices; ++i) {
            Eigen::Vector3d v;
            for (int a = 0; a < 3; ++a) v[a] = r.GetFinite("mesh vertex");
            model.mesh.vertices.push_back(v);
        }
        const uint64_t triangles = r.Get<uint64_t>();
        if (!r.ok() || triangles > r.Remaining() / (3 * sizeof(int32_t))) {
            r.Fail("mesh triangle count exceeds the payload");
        }
        for (uint64_t i = 0; r.ok() && i < triangles; ++i) {
            Eigen::Vector3i t;
            for (int a = 0; a < 3; ++a) t[a] = r.Get<int32_t>();
            if ((t.array() < 0).any() ||
                (t.array() >= static_cast<int>(model.mesh.vertices.size())).any()) {
                r.Fail("mesh triangle index is out of range");
            }
            model.mesh.triangles.push_back(t);
        }
    }
    model.structure_radius_m = r.GetFinite("structure radius");
    model.smoothing_radius_m = r.GetFinite("smoothing radius");
    model.column_top_m = r.GetFinite("column top");
    model.observed_share = r.GetFinite("observed share");
    model.depth_m = r.GetFinite("depth");
    model.struck_capacity_m3 = r.GetFinite("struck capacity");
    model.heaped_capacity_sae_m3 = r.GetFinite("heaped capacity (SAE)");
    model.heaped_capacity_iso_m3 = r.GetFinite("heaped capacity (ISO)");
    model.noise_sigma_m = r.GetFinite("noise sigma");
    model.scan_points = r.Get<uint64_t>();
    model.outside_points = r.Get<uint64_t>();
    if (r.ok() && r.Remaining() != 0) r.Fail("payload has trailing bytes");
    if (!r.ok()) return absl::DataLossError(absl::StrCat("container model: ", r.error()));
    model.cache = std::make_shared<ModelCache>();
    return model;
}

}  // namespace

std::string EncodeModel(const ContainerModel& model) {
    const std::string payload = EncodePayload(model);
    Writer w;
    for (const char c : kMagic) w.Put<char>(c);
    w.Put<uint32_t>(kModelCodecVersion);
    w.Put<uint32_t>(0);
    w.Put<uint64_t>(payload.size());
    std::string out = w.Take();
    out += payload;
    Writer tail;
    tail.Put<uint64_t>(Fnv1a64(payload));
    out += tail.Take();
    return out;
}

absl::StatusOr<ContainerModel> DecodeModel(std::string_view bytes) {
    if (bytes.size() < kHeaderBytes + 8 || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
        return absl::DataLossError("container model: not a soilvol model (bad magic or too short)");
    }
    Reader header(bytes.substr(sizeof(kMagic), kHeaderBytes - sizeof(kMagic)));
    const uint32_t version = header.Get<uint32_t>();
    header.Get<uint32_t>();
    const uint64_t size = header.Get<uint64_t>();
    if (version < kOldestModelCodecVersion || version > kModelCodecVersion) {
        return absl::FailedPreconditionError(
            absl::StrCat("container model: version ", version, " (this build reads ",
                         kOldestModelCodecVersion, " to ", kModelCodecVersion, ")"));
    }
    if (size != bytes.size() - kHeaderBytes - 8) {
        return absl::DataLossError(
            absl::StrCat("container model: payload size ", size, " does not match the file"));
    }
    const std::string_view payload = bytes.substr(kHeaderBytes, size);
    Reader tail(bytes.substr(kHeaderBytes + size));
    if (tail.Get<uint64_t>() != Fnv1a64(payload)) {
        return absl::DataLossError("container model: checksum mismatch (the file is damaged)");
    }
    return DecodePayload(payload, version);
}

}  // namespace soilvol::model

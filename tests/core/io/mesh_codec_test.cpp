#include "core/io/mesh_codec.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "tests/core/io/codec_test_util.hpp"

// Largest single allocation since the last reset [bytes]: shows that declared counts are checked
// before anything is reserved for them.
namespace {
std::atomic<std::size_t> g_largest_allocation{0};
}  // namespace

void* operator new(std::size_t size) {
    std::size_t seen = g_largest_allocation.load(std::memory_order_relaxed);
    while (size > seen && !g_largest_allocation.compare_exchange_weak(seen, size)) {
    }
    if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace soilvol::io {
namespace {

using test::Append;

constexpr double kTolerance = 1e-12;

// The unit cube [0, 1]^3: 8 corners, 12 triangles counter-clockwise seen from outside.
DecodedMesh UnitCube() {
    DecodedMesh cube;
    for (int i = 0; i < 8; ++i) {
        const int x = (i == 1 || i == 2 || i == 5 || i == 6) ? 1 : 0;
        const int y = (i == 2 || i == 3 || i == 6 || i == 7) ? 1 : 0;
        cube.vertices.emplace_back(x, y, i >= 4 ? 1 : 0);
    }
    cube.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                      {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
    return cube;
}

// The cube's faces as quads, counter-clockwise from outside (0-based).
const std::vector<std::vector<int>> kCubeQuads = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                                  {3, 7, 6, 2}, {0, 4, 7, 3}, {1, 2, 6, 5}};

double SurfaceArea(const DecodedMesh& mesh) {
    double area = 0.0;
    for (const Eigen::Vector3i& t : mesh.triangles) {
        const Eigen::Vector3d& a = mesh.vertices[t[0]];
        area += 0.5 * (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a).norm();
    }
    return area;
}

// Divergence theorem: the signed tetrahedra from the origin to each outward triangle.
double EnclosedVolume(const DecodedMesh& mesh) {
    double volume = 0.0;
    for (const Eigen::Vector3i& t : mesh.triangles) {
        volume += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]])) / 6.0;
    }
    return volume;
}

::testing::AssertionResult IsUnitCube(const absl::StatusOr<DecodedMesh>& mesh) {
    if (!mesh.ok()) return ::testing::AssertionFailure() << mesh.status();
    if (mesh->triangles.size() != 12 || mesh->vertices.size() != 8) {
        return ::testing::AssertionFailure() << mesh->triangles.size() << " triangles and "
                                             << mesh->vertices.size() << " vertices";
    }
    if (std::abs(SurfaceArea(*mesh) - 6.0) > kTolerance ||
        std::abs(EnclosedVolume(*mesh) - 1.0) > kTolerance) {
        return ::testing::AssertionFailure()
               << "area " << SurfaceArea(*mesh) << ", volume " << EnclosedVolume(*mesh);
    }
    return ::testing::AssertionSuccess();
}

::testing::AssertionResult IsInvalidWith(const absl::StatusOr<DecodedMesh>& result,
                                         std::string_view needle) {
    if (result.ok()) return ::testing::AssertionFailure() << "decoded OK, expected an error";
    if (result.status().code() != absl::StatusCode::kInvalidArgument) {
        return ::testing::AssertionFailure() << "wrong code: " << result.status();
    }
    if (std::string(result.status().message()).find(needle) == std::string::npos) {
        return ::testing::AssertionFailure()
               << "message \"" << result.status().message() << "\" lacks \"" << needle << "\"";
    }
    return ::testing::AssertionSuccess();
}

std::string CubeObj(bool negative_indices) {
    std::string out = "# a unit cube\nmtllib cube.mtl\no cube\n";
    for (const Eigen::Vector3d& v : UnitCube().vertices) {
        out += "v " + std::to_string(v.x()) + " " + std::to_string(v.y()) + " " +
               std::to_string(v.z()) + "\n";
    }
    out += "vt 0 0\nvn 0 0 1\nusemtl soil\ns off\n";
    static const char* const kForms[] = {"", "/1", "//1", "/1/1"};
    for (std::size_t f = 0; f < kCubeQuads.size(); ++f) {
        out += "f";
        for (const int index : kCubeQuads[f]) {
            const int written = negative_indices ? index - 8 : index + 1;
            out += " " + std::to_string(written) + kForms[f % 4];
        }
        out += "\n";
    }
    return out;
}

// The cube as PLY: `count_type` is the face list's count type, indices are int.
std::string CubePly(std::string_view format, std::string_view count_type) {
    const DecodedMesh cube = UnitCube();
    std::string out = "ply\nformat " + std::string(format) +
                      " 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 12\nproperty list " +
                      std::string(count_type) + " int vertex_indices\nend_header\n";
    const bool ascii = format == "ascii";
    const bool big_endian = format == "binary_big_endian";
    for (const Eigen::Vector3d& v : cube.vertices) {
        for (int axis = 0; axis < 3; ++axis) {
            if (ascii) {
                out += std::to_string(v[axis]) + (axis < 2 ? " " : "\n");
            } else {
                Append<float>(static_cast<float>(v[axis]), &out, big_endian);
            }
        }
    }
    for (const Eigen::Vector3i& t : cube.triangles) {
        if (ascii) {
            out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " +
                   std::to_string(t[2]) + "\n";
            continue;
        }
        if (count_type == "uchar") {
            Append<std::uint8_t>(3, &out, big_endian);
        } else {
            Append<std::int32_t>(3, &out, big_endian);
        }
        for (int k = 0; k < 3; ++k) Append<std::int32_t>(t[k], &out, big_endian);
    }
    return out;
}

// A binary STL header (zero padded) declaring `count` facets, followed by `body_bytes` zeros.
std::string StlWithCount(std::uint32_t count, std::size_t body_bytes) {
    std::string out(80, '\0');
    Append<std::uint32_t>(count, &out);
    return out + std::string(body_bytes, '\0');
}

TEST(MeshCodecTest, BinaryStlCubeDecodesToTwelveTrianglesAndEightVertices) {
    const absl::StatusOr<DecodedMesh> mesh = DecodeMesh(EncodeStl(UnitCube()));
    EXPECT_TRUE(IsUnitCube(mesh));
    EXPECT_EQ(mesh->format, MeshFormat::kStlBinary);
    EXPECT_EQ(mesh->dropped_degenerate, 0u);
}

TEST(MeshCodecTest, AsciiStlCubeDecodesToTheSameSolid) {
    const absl::StatusOr<DecodedMesh> mesh = DecodeMesh(EncodeStl(UnitCube(), /*binary=*/false));
    EXPECT_TRUE(IsUnitCube(mesh));
    EXPECT_EQ(mesh->format, MeshFormat::kStlAscii);
}

TEST(MeshCodecTest, BinaryStlWhoseHeaderStartsWithSolidIsReadAsBinary) {
    std::string bytes = EncodeStl(UnitCube());
    bytes.replace(0, 11, "solid cube ");
    const absl::StatusOr<DecodedMesh> mesh = DecodeMesh(bytes);
    EXPECT_TRUE(IsUnitCube(mesh));
    EXPECT_EQ(mesh->format, MeshFormat::kStlBinary);
}

TEST(MeshCodecTest, AsciiStlWithSeveralSolidsAndCrlfDecodes) {
    std::string text = EncodeStl(UnitCube(), /*binary=*/false);
    const std::size_t middle = text.find("  facet", text.size() / 2);
    text.insert(middle, "endsolid soilvol\nsolid second\n");
    for (std::size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at + 2)) {
        text.insert(at, "\r");
    }
    EXPECT_TRUE(IsUnitCube(DecodeMesh(text)));
}

TEST(MeshCodecTest, ObjCubeOfQuadsIsFanTriangulated) {
    const absl::StatusOr<DecodedMesh> mesh = DecodeMesh(CubeObj(/*negative_indices=*/false));
    EXPECT_TRUE(IsUnitCube(mesh));
    EXPECT_EQ(mesh->format, MeshFormat::kObj);
}

TEST(MeshCodecTest, ObjNegativeRelativeIndicesResolve) {
    EXPECT_TRUE(IsUnitCube(DecodeMesh(CubeObj(/*negative_indices=*/true))));
}

TEST(MeshCodecTest, ObjPentagonGivesThreeTrianglesAndForwardReferencesResolve) {
    const absl::StatusOr<DecodedMesh> mesh = DecodeMesh(
        "f 1 2 3 4 5 # a pentagon before its vertices\n"
        "v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0 1.0\n");
    ASSERT_TRUE(mesh.ok()) << mesh.status();
    EXPECT_EQ(mesh->triangles.size(), 3u);
    EXPECT_NEAR(SurfaceArea(*mesh), 5.0, kTolerance);  // shoelace: 10 / 2
}

TEST(MeshCodecTest, PlyCubeDecodesInEveryEncodingWithUcharAndIntCounts) {
    for (const char* format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
        for (const char* count_type : {"uchar", "int"}) {
            SCOPED_TRACE(std::string(format) + " " + count_type);
            const absl::StatusOr<DecodedMesh> mesh = DecodeMesh(CubePly(format, count_type));
            EXPECT_TRUE(IsUnitCube(mesh));
            EXPECT_EQ(mesh->format, MeshFormat::kPly);
        }
    }
}

TEST(MeshCodecTest, PlyFacesBeforeVerticesAndOtherElementsDecode) {
    const DecodedMesh cube = UnitCube();
    std::string bytes =
        "ply\nformat binary_little_endian 1.0\ncomment faces first\nelement material 1\n"
        "property list uchar uchar name\nelement face 6\nproperty uchar flags\n"
        "property list uint8 uint32 vertex_index\nproperty list uchar float texcoord\n"
        "element vertex 8\nproperty double x\nproperty double y\nproperty double z\n"
        "property uchar red\nelement edge 1\nproperty int a\nend_header\n";
    Append<std::uint8_t>(2, &bytes);
    bytes += "ab";
    for (const std::vector<int>& quad : kCubeQuads) {
        Append<std::uint8_t>(7, &bytes);
        Append<std::uint8_t>(4, &bytes);
        for (const int index : quad)
            Append<std::uint32_t>(static_cast<std::uint32_t>(index), &bytes);
        Append<std::uint8_t>(1, &bytes);
        Append<float>(0.5f, &bytes);
    }
    for (const Eigen::Vector3d& v : cube.vertices) {
        for (int axis = 0; axis < 3; ++axis) Append<double>(v[axis], &bytes);
        Append<std::uint8_t>(255, &bytes);
    }
    EXPECT_TRUE(IsUnitCube(DecodeMesh(bytes)));  // the edge element is missing: never read
}

TEST(MeshCodecTest, DegenerateFacesAreDroppedAndCounted) {
    DecodedMesh mesh = UnitCube();
    mesh.vertices.emplace_back(2.0, 0.0, 0.0);  // on the line through corners 0 and 1
    mesh.triangles.emplace_back(0, 0, 1);       // repeated index
    mesh.triangles.emplace_back(0, 1, 8);       // zero area
    std::string obj;
    for (const Eigen::Vector3d& v : mesh.vertices) {
        obj += "v " + std::to_string(v.x()) + " " + std::to_string(v.y()) + " " +
               std::to_string(v.z()) + "\n";
    }
    for (const Eigen::Vector3i& t : mesh.triangles) {
        obj += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " +
               std::to_string(t[2] + 1) + "\n";
    }
    const absl::StatusOr<DecodedMesh> decoded = DecodeMesh(obj);
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_EQ(decoded->triangles.size(), 12u);
    EXPECT_EQ(decoded->dropped_degenerate, 2u);
    EXPECT_NEAR(EnclosedVolume(*decoded), 1.0, kTolerance);
    // Through STL the repeated corner is merged too: still dropped, still counted.
    const absl::StatusOr<DecodedMesh> stl = DecodeMesh(EncodeStl(mesh));
    ASSERT_TRUE(stl.ok()) << stl.status();
    EXPECT_EQ(stl->triangles.size(), 12u);
    EXPECT_EQ(stl->dropped_degenerate, 2u);
}

TEST(MeshCodecTest, EncodedStlKeepsEveryCornerBitForBit) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> coordinate(-50.0f, 50.0f);
    DecodedMesh mesh;
    for (int i = 0; i < 300; ++i) {
        mesh.vertices.emplace_back(coordinate(rng), coordinate(rng), coordinate(rng));
    }
    std::uniform_int_distribution<int> index(0, 299);
    for (int i = 0; i < 500; ++i) mesh.triangles.emplace_back(index(rng), index(rng), index(rng));
    // Extremes: the largest float, a negative zero, the smallest subnormal.
    constexpr auto kMax = static_cast<double>(std::numeric_limits<float>::max());
    mesh.vertices.emplace_back(kMax, -0.0,
                               static_cast<double>(std::numeric_limits<float>::denorm_min()));
    mesh.vertices.emplace_back(0.0, kMax, 0.0);
    mesh.vertices.emplace_back(0.0, 0.0, -kMax);
    mesh.triangles.emplace_back(300, 301, 302);
    for (const bool binary : {true, false}) {
        const absl::StatusOr<DecodedMesh> decoded = DecodeMesh(EncodeStl(mesh, binary));
        ASSERT_TRUE(decoded.ok()) << decoded.status();
        std::size_t kept = 0;
        for (const Eigen::Vector3i& t : mesh.triangles) {
            if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;
            const Eigen::Vector3i& d = decoded->triangles.at(kept++);
            for (int k = 0; k < 3; ++k) {
                EXPECT_EQ(decoded->vertices[d[k]], mesh.vertices[t[k]]) << "binary " << binary;
            }
        }
        EXPECT_EQ(kept, decoded->triangles.size());
    }
}

TEST(MeshCodecTest, EmptyInputIsRejected) { EXPECT_TRUE(IsInvalidWith(DecodeMesh(""), "empty")); }

TEST(MeshCodecTest, TextGarbageIsUnrecognised) {
    for (const char* text : {"hello world\n", "solid but then\nnothing like a facet\n",
                             "vertex 1 2 3\nface 1 2 3\n", "{\"json\": true}"}) {
        EXPECT_TRUE(IsInvalidWith(DecodeMesh(text), "unrecognised mesh format")) << text;
    }
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> printable(0x20, 0x7e);
    std::string noise(4096, ' ');
    for (char& c : noise) c = static_cast<char>(printable(rng));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(noise), "unrecognised mesh format"));
}

TEST(MeshCodecTest, TruncatedBinaryStlIsRejected) {
    const std::string bytes = EncodeStl(UnitCube());
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(bytes.substr(0, 400)),
                              "declares 12 triangles (684 bytes) but the input has 400"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(bytes.substr(0, 83)), "shorter than the 84-byte header"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(bytes + "xx"), "but the input has 686 bytes"));
}

TEST(MeshCodecTest, TriangleCountOfTwoToThe32MinusOneInATinyFileIsRejected) {
    EXPECT_TRUE(
        IsInvalidWith(DecodeMesh(StlWithCount(0xffffffffu, 100)), "declares 4294967295 triangles"));
}

TEST(MeshCodecTest, BinaryStlBeyondTheBudgetIsRejected) {
    MeshBudget budget;
    budget.max_triangles = 11;
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(EncodeStl(UnitCube()), budget),
                              "12 triangles is more than the budget of 11"));
    budget = MeshBudget();
    budget.max_vertices = 7;
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(EncodeStl(UnitCube()), budget), "budget of 7 vertices"));
}

TEST(MeshCodecTest, HundredMegabytesOfDeclaredVerticesInOneKilobyteFailWithoutAllocating) {
    // 8738134 vertices of 12 bytes: 104857608 bytes declared.
    std::string ply =
        "ply\nformat binary_little_endian 1.0\nelement vertex 8738134\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\n"
        "property list uchar int vertex_indices\nend_header\n";
    ply.resize(1024, '\0');
    MeshBudget roomy;
    roomy.max_vertices = 100'000'000;
    roomy.max_triangles = 100'000'000;
    const std::string stl = StlWithCount(2'000'000, 1024 - 84);
    g_largest_allocation = 0;
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ply), "vertex count 8738134 is more than the budget"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ply, roomy), "needs 104857608 bytes but only"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(stl, roomy), "declares 2000000 triangles"));
    EXPECT_LT(g_largest_allocation.load(), std::size_t{64 * 1024});
}

TEST(MeshCodecTest, PlyFaceCountBeyondThePayloadIsRejected) {
    std::string binary = CubePly("binary_little_endian", "uchar");
    binary.replace(binary.find("face 12"), 7, "face 999");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(binary), "face count 999 needs at least 999 bytes"));
    binary.replace(binary.find("face 999"), 8, "face 13");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(binary), "element 'face' is truncated"));
    std::string ascii = CubePly("ascii", "int");
    ascii.replace(ascii.find("face 12"), 7, "face 50");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ascii), "expected 50 face lines but the data ends"));
    ascii.replace(ascii.find("face 50"), 7, "face 5000");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ascii), "face count 5000 cannot fit"));
}

TEST(MeshCodecTest, PlyListLengthOf255WithThreeValuesIsRejected) {
    std::string binary = CubePly("binary_big_endian", "uchar");
    binary.resize(binary.size() - 13);  // the last face, replaced by 255 and three indices
    Append<std::uint8_t>(255, &binary, /*big_endian=*/true);
    for (int k = 0; k < 3; ++k) Append<std::int32_t>(k, &binary, /*big_endian=*/true);
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(binary), "element 'face' is truncated"));
    std::string ascii = CubePly("ascii", "uchar");
    ascii.replace(ascii.rfind("3 "), 1, "255");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ascii), "face 12 has too few values"));
}

TEST(MeshCodecTest, PlyIndexProblemsAreRejected) {
    std::string ascii = CubePly("ascii", "uchar");
    const std::size_t last = ascii.rfind("3 ");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ascii.substr(0, last) + "3 1 6 8\n"),
                              "face 12 refers to vertex 8 but the mesh has 8 vertices"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ascii.substr(0, last) + "3 1 -6 5\n"),
                              "'-6' is not a vertex index"));
    EXPECT_TRUE(
        IsInvalidWith(DecodeMesh(ascii.substr(0, last) + "2 1 6\n"), "face 12 has 2 corners"));
    std::string bytes = CubePly("binary_little_endian", "int");
    bytes.replace(bytes.size() - 4, 4, std::string("\xff\xff\xff\xff", 4));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(bytes), "face 12 has a negative index"));
}

TEST(MeshCodecTest, PlyWithoutAnIntegerFaceListIsRejected) {
    std::string cloud = EncodePly({{0.0f, 0.0f, 0.0f}});
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(cloud), "no face element"));
    std::string floats = CubePly("ascii", "uchar");
    floats.replace(floats.find("int vertex_indices"), 3, "float");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(floats), "expected an integer type"));
}

TEST(MeshCodecTest, ObjOutOfRangeAndZeroIndicesAreRejected) {
    const std::string cube = CubeObj(/*negative_indices=*/false);
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(cube + "f 1 2 9\n"),
                              "face 7 refers to vertex 9 but the mesh has 8 vertices"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(cube + "f 0 1 2\n"), "line 22: vertex index 0"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(cube + "f -9 1 2\n"), "relative index -9 reaches"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(cube + "f 1 x 2\n"), "'x' is not a vertex reference"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(cube + "f 1 99999999999999999999 2\n"),
                              "is not a vertex reference"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(cube + "f 1 2\n"), "has 2 corners"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(cube + "v 1 2\n"), "a vertex needs x, y and z"));
}

TEST(MeshCodecTest, NanCoordinatesAreRejectedNamingTheVertexOrFacet) {
    const std::string obj = CubeObj(/*negative_indices=*/false);
    std::string nan_obj = obj;
    nan_obj.replace(nan_obj.find("v 1.000000 1.000000 0.000000"), 28, "v 1 nan 0");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(nan_obj), "vertex 3 has a NaN/Inf coordinate"));
    std::string ply = CubePly("binary_little_endian", "int");
    const std::size_t body = ply.find("end_header\n") + 11;
    ply.replace(body + 12 * 4 + 8, 4, std::string("\x00\x00\x80\x7f", 4));  // +Inf
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ply), "vertex 5 has a NaN/Inf coordinate"));
    std::string stl = EncodeStl(UnitCube());
    stl.replace(84 + 50 + 12, 4, std::string("\x00\x00\xc0\x7f", 4));  // NaN
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(stl), "facet 2 has a NaN/Inf coordinate"));
    std::string ascii = EncodeStl(UnitCube(), /*binary=*/false);
    ascii.replace(ascii.find("vertex 0 1 0"), 12, "vertex 0 inf 0");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(ascii), "has a NaN/Inf coordinate"));
}

TEST(MeshCodecTest, MalformedAsciiStlIsRejectedNamingTheLine) {
    const std::string good = EncodeStl(UnitCube(), /*binary=*/false);
    std::string no_loop = good;
    no_loop.replace(no_loop.find("outer loop"), 10, "outer");
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(no_loop), "line 4: expected 'loop', found 'vertex'"));
    const std::string half = good.substr(0, good.find('\n', good.size() / 2) + 1);
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(half), "input ends"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(good + "junk\n"), "'junk' after 'endsolid'"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh("solid empty\nendsolid empty\n"), "no triangles"));
}

TEST(MeshCodecTest, OnlyDegenerateFacesLeaveNoValidTriangle) {
    EXPECT_TRUE(IsInvalidWith(DecodeMesh("v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\nf 1 1 2\n"),
                              "no valid triangle (all 2 are degenerate)"));
}

TEST(MeshCodecTest, TextPastTheBudgetIsRejected) {
    MeshBudget budget;
    budget.max_vertices = 5;
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(CubeObj(false), budget), "budget of 5 vertices"));
    budget = MeshBudget();
    budget.max_triangles = 10;
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(CubeObj(false), budget), "budget of 10 triangles"));
    EXPECT_TRUE(
        IsInvalidWith(DecodeMesh(EncodeStl(UnitCube(), false), budget), "budget of 10 triangles"));
    EXPECT_TRUE(IsInvalidWith(DecodeMesh(CubePly("ascii", "int"), budget),
                              "face count 12 is more than the budget of 10 triangles"));
}

}  // namespace
}  // namespace soilvol::io

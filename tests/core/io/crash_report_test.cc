#include "core/io/crash_report.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <string>
#include <vector>

#include "core/io/file_bytes.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace meshsmooth {
namespace {

using ::testing::ElementsAre;

// AddressSanitizer's report of a heap overflow in Draco's glTF decoder, as fuzz_gltf's children
// wrote them (libdraco has no line tables: its frames name the binary; ours name the source).
constexpr char kDracoOverflow[] = R"(=================================================================
==4242==ERROR: AddressSanitizer: heap-buffer-overflow on address 0x602000001234 at pc 0x55d1 bp 0x7ffc sp 0x7ffc
READ of size 12 at 0x602000001234 thread T0
    #0 0x55d1a3 in __asan_memcpy (/w/build-fuzz/fuzz/fuzz_gltf+0x4d51a3) (BuildId: 0a1b)
    #1 0x55e0f2 in void draco::TriangleSoupMeshBuilder::SetAttributeValuesForFace<float>(int, draco::IndexType<unsigned int, draco::FaceIndex_tag_type_>, void const*, void const*, void const*) (/w/build-fuzz/fuzz/fuzz_gltf+0x4e00f2)
    #2 0x55e311 in draco::GltfDecoder::SetValuesPerFace(draco::GltfDecoder::GltfPrimitive const&) (/w/build-fuzz/fuzz/fuzz_gltf+0x4e0311)
    #3 0x55e499 in draco::ReadSceneFromFile(std::__cxx11::basic_string<char, std::char_traits<char>, std::allocator<char> > const&) (/w/build-fuzz/fuzz/fuzz_gltf+0x4e0499)
    #4 0x52a001 in meshsmooth::GltfScene::Read(std::__cxx11::basic_string<char, std::char_traits<char>, std::allocator<char> > const&) /w/core/io/gltf.cc:121:62
    #5 0x7f00aa in __libc_start_main (/lib/x86_64-linux-gnu/libc.so.6+0x271c9)

0x602000001234 is located 0 bytes to the right of 4-byte region [0x602000001230,0x602000001234)
allocated by thread T0 here:
    #0 0x55c001 in operator new(unsigned long) (/w/build-fuzz/fuzz/fuzz_gltf+0x4c0001)
    #1 0x52b002 in meshsmooth::(anonymous namespace)::Elsewhere() /w/core/io/gltf.cc:40:3

SUMMARY: AddressSanitizer: heap-buffer-overflow (/w/build-fuzz/fuzz/fuzz_gltf+0x4e00f2) in draco::TriangleSoupMeshBuilder
==4242==ABORTING
)";

// A null dereference in a lambda of ours, inside a standard algorithm, called with Draco's data.
constexpr char kOurSegv[] = R"(AddressSanitizer:DEADLYSIGNAL
==77==ERROR: AddressSanitizer: SEGV on unknown address 0x000000000000 (pc 0x52a0 bp 0x7ffd sp 0x7ffd T0)
==77==The signal is caused by a READ memory access.
    #0 0x52a0 in meshsmooth::GltfScene::Read(std::string const&)::$_0::operator()(draco::Mesh const&) const /w/core/io/gltf.cc:140:9
    #1 0x52a1 in void std::for_each<draco::Mesh const*, meshsmooth::GltfScene::Read(std::string const&)::$_0>(draco::Mesh const*, draco::Mesh const*, meshsmooth::GltfScene::Read(std::string const&)::$_0) /usr/include/c++/12/bits/stl_algo.h:3880:5
    #2 0x52a2 in meshsmooth::GltfScene::Read(std::string const&) /w/core/io/gltf.cc:139:3
    #3 0x52a3 in draco::Scene::~Scene() (/w/fuzz_gltf+0x9)

SUMMARY: AddressSanitizer: SEGV /w/core/io/gltf.cc:140:9 in meshsmooth::GltfScene::Read(std::string const&)::$_0::operator()(draco::Mesh const&) const
)";

TEST(CrashReportTest, AHeapOverflowInDracosFramesIsDracos) {
  const CrashReport r = ReadCrashReport(kDracoOverflow);
  EXPECT_EQ(r.owner, CrashOwner::kDraco);
  EXPECT_EQ(r.kind, "heap-buffer-overflow");
  // The interceptor is passed over; the allocation's stack is not read.
  EXPECT_THAT(r.frames, ElementsAre("draco::TriangleSoupMeshBuilder::SetAttributeValuesForFace<float>",
                                    "draco::GltfDecoder::SetValuesPerFace", "draco::ReadSceneFromFile",
                                    "meshsmooth::GltfScene::Read"));
}

TEST(CrashReportTest, ASegvInOurFramesIsOursThroughTheStandardLibrary) {
  const CrashReport r = ReadCrashReport(kOurSegv);
  EXPECT_EQ(r.owner, CrashOwner::kMeshsmooth);
  EXPECT_EQ(r.kind, "SEGV");
  EXPECT_THAT(r.frames,
              ElementsAre("meshsmooth::GltfScene::Read", "meshsmooth::GltfScene::Read", "draco::Scene::~Scene"));
}

TEST(CrashReportTest, UndefinedBehaviourIsReadByItsStack) {
  const CrashReport r = ReadCrashReport(
      "/w/core/io/gltf.cc:150:20: runtime error: load of value 190, which is not a valid value for type 'bool'\n"
      "    #0 0x5 in meshsmooth::GltfScene::Write(std::vector<meshsmooth::Vec3> const&, std::string const&, bool) "
      "/w/core/io/gltf.cc:150:20\n"
      "    #1 0x6 in draco::Foo() (/w/fuzz_gltf+0x6)\n\n"
      "SUMMARY: UndefinedBehaviorSanitizer: undefined-behavior /w/core/io/gltf.cc:150:20 in \n");
  EXPECT_EQ(r.owner, CrashOwner::kMeshsmooth);
  EXPECT_EQ(r.kind, "undefined-behavior");
  EXPECT_THAT(r.frames, ElementsAre("meshsmooth::GltfScene::Write", "draco::Foo"));
}

// SendCrashReportsTo's own lines: names as Abseil's symbolizer gives them (demangled, or mangled
// when it cannot), no location.
TEST(CrashReportTest, SignalHandlersLinesAreRead) {
  const CrashReport r = ReadCrashReport(
      "SUMMARY: deadly signal: SEGV\n"
      "    #0 0x7f01\n"
      "    #1 0x4a02 in nlohmann::basic_json<>::parse<>()\n"
      "    #2 0x4a03 in _ZN8tinygltfL9ParseMeshEPNS_4MeshEPNS_5ModelE\n"
      "    #3 0x4a04 in tinygltf::TinyGLTF::LoadBinaryFromMemory()\n"
      "    #4 0x4a05 in meshsmooth::(anonymous namespace)::ReadAndWriteInChild()\n"
      "    #5 0x4a06 in _ZNK10meshsmooth9GltfScene6countsEv\n");
  EXPECT_EQ(r.owner, CrashOwner::kDraco);
  EXPECT_EQ(r.kind, "SEGV");
  EXPECT_THAT(
      r.frames,
      ElementsAre("_ZN8tinygltfL9ParseMeshEPNS_4MeshEPNS_5ModelE", "tinygltf::TinyGLTF::LoadBinaryFromMemory",
                  "meshsmooth::(anonymous namespace)::ReadAndWriteInChild", "_ZNK10meshsmooth9GltfScene6countsEv"));
}

TEST(CrashReportTest, NamesAreQualifiedNamesWithoutTypesOrParameters) {
  const auto first = [](const std::string& function) {
    const CrashReport r = ReadCrashReport("    #0 0x1 in " + function + "\n");
    return r.frames.empty() ? std::string("(none)") : r.frames[0];
  };
  EXPECT_EQ(first("draco::Mesh::operator()(int) const /a.h:3"), "draco::Mesh::operator()");
  EXPECT_EQ(first("bool draco::operator==(draco::Foo const&, draco::Foo const&)"), "draco::operator==");
  EXPECT_EQ(first("std::unique_ptr<draco::Mesh> meshsmooth::Make<draco::Mesh, 2>(int (*)(int))"),
            "meshsmooth::Make<draco::Mesh, 2>");
  EXPECT_EQ(first("meshsmooth::Foo()::{lambda(int)#1}::operator()(int) const"), "meshsmooth::Foo");
  EXPECT_EQ(first("draco::Decode (/w/bin+0x4)"), "draco::Decode");
  EXPECT_EQ(first("meshsmooth::Decode /w/core/io/x.cc:12"), "meshsmooth::Decode");
  // Neither Draco's nor ours: not listed.
  EXPECT_EQ(first("std::vector<draco::Mesh, std::allocator<draco::Mesh> >::at(unsigned long)"), "(none)");
  EXPECT_EQ(first("meshsmoothing::Foo()"), "(none)");
  EXPECT_EQ(first("dracox::Foo()"), "(none)");
}

TEST(CrashReportTest, AStackThatNamesNeitherIsUnknown) {
  const CrashReport r = ReadCrashReport("SUMMARY: deadly signal: ABRT\n    #0 0x7f01\n    #1 0x7f02 in abort\n");
  EXPECT_EQ(r.owner, CrashOwner::kUnknown);
  EXPECT_EQ(r.kind, "ABRT");
  EXPECT_TRUE(r.frames.empty());
  EXPECT_EQ(ReadCrashReport("").owner, CrashOwner::kUnknown);
}

// An unmapped address the compiler cannot see (it would make the store a trap instruction). Not
// null: UBSan would stop a null store first, with a report of its own runtime's on stderr.
int* volatile unmapped = reinterpret_cast<int*>(uintptr_t{64});

// Kept out of line so that it is a frame of its own, in namespace meshsmooth.
[[gnu::noinline]] void StoreToUnmappedAddress() { *unmapped = 1; }

// A child that crashes in our code after SendCrashReportsTo leaves a report that says so, in
// every build: the handler's stack in a plain one, the same in a sanitized one (it replaces the
// sanitizer's SIGSEGV handler).
TEST(CrashReportTest, AChildsCrashInOurCodeIsReportedAsOurs) {
  int fds[2];
  ASSERT_EQ(pipe2(fds, O_CLOEXEC), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    close(fds[0]);
    SendCrashReportsTo(fds[1]);
    StoreToUnmappedAddress();
    _exit(0);
  }
  close(fds[1]);
  std::string report;
  EXPECT_EQ(ReadToEnd(fds[0], &report), 0);
  close(fds[0]);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGSEGV) << status;
  const CrashReport r = ReadCrashReport(report);
  EXPECT_EQ(r.owner, CrashOwner::kMeshsmooth) << report;
  EXPECT_EQ(r.kind, "SEGV") << report;
  ASSERT_FALSE(r.frames.empty()) << report;
  EXPECT_NE(r.frames[0].find("StoreToUnmappedAddress"), std::string::npos) << report;
}

}  // namespace
}  // namespace meshsmooth

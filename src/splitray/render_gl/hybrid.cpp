#include "splitray/render_gl/hybrid.hpp"

#include <algorithm>
#include <cmath>
#include <future>
#include <glm/gtc/type_ptr.hpp>
#include <optional>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/render/surface.hpp"
#include "splitray/render_gl/cpu_pass.hpp"
#include "splitray/render_gl/gl_context.hpp"
#include "splitray/render_gl/gl_util.hpp"
#include "splitray/render_gl/light_space.hpp"

namespace splitray {

namespace {

using gl::Program;

// Texture units of the id pass's shadow samplers, one range per sampler array.
constexpr int kUnitMap = 1, kUnitFlag = 5, kUnitCube = 9, kUnitCubeFlag = 13;

struct Vertex {
  float position[3], normal[3], geometric_normal[3];
  std::uint32_t material;
  float uv[2];
};

struct MaterialGpu {
  float diffuse_share[4], specular_shine[4], flags[4];  // flags: transparency, texture (-1 none)
  float ambient[4];  // a = 1: the material's own ambient colour, 0: the diffuse colour
};

struct TextureGpu {
  std::int32_t width, height, offset, wrap;  // wrap: u's WrapMode | v's << 2
};

struct ShadowMap {
  bool cube = false;
  int size = 0;
  GLuint depth = 0, flag = 0;
  GLuint fbo[6] = {};
  glm::mat4 matrix{1.0f};            // directional lights
  std::array<glm::mat4, 6> faces{};  // of this frame: matrix, or the cube's faces
  float range = 1;                   // point lights
  float normal_offset = 0;
};

// The triangles of one frame on both sides: the CPU's soup, hierarchy and pass, the GPU's
// vertex buffer. Frames in flight hold their own (animation: frame n-1's CPU pass and
// composite use frame n-1's geometry while the GPU rasterises frame n's).
struct Geometry {
  FlatScene flat;
  std::unique_ptr<Accel> accel;
  std::unique_ptr<gl::CpuPass> cpu;
  Aabb bounds;
  GLuint vao = 0, vbo = 0;
  std::size_t vertex_count = 0;

  Geometry() = default;
  Geometry(const Geometry&) = delete;
  Geometry& operator=(const Geometry&) = delete;
  ~Geometry() {  // released on the GL thread only (slots and the renderer live there)
    glDeleteBuffers(1, &vbo);
    glDeleteVertexArrays(1, &vao);
  }
};

// Everything one frame carries between the GPU passes and the CPU pass (double-buffered).
struct Slot {
  std::shared_ptr<Geometry> geometry;
  gl::CpuPassInput input;
  gl::CpuPassOutput output;
  HybridFrame frame;
};

void check_options(const HybridOptions& o) {
  if (o.width <= 0 || o.height <= 0)
    throw Error("--size", "the image must be at least 1x1 pixels, got " + std::to_string(o.width) +
                              "x" + std::to_string(o.height));
  if (o.max_depth < 0) throw Error("--max-depth", "must be 0 or more");
  if (o.blur_kernel < 1 || o.blur_kernel % 2 == 0 || o.blur_kernel > 31)
    throw Error("--blur-kernel",
                "must be odd and in [1, 31], got " + std::to_string(o.blur_kernel));
  if (o.shadow_map_size < 16 || o.shadow_map_size > 8192)
    throw Error("--shadow-map-size", "must be in [16, 8192]");
}

}  // namespace

struct HybridRenderer::Impl {
  const Scene& scene;
  HybridOptions options;
  std::shared_ptr<Geometry> geometry;  // of the next frame submitted
  std::vector<Light> view_lights;      // the scene's, or fitted to the first camera's view
  std::size_t lights = 0;
  bool has_secondary = false;  // a material reflects or refracts

  GLuint materials = 0, texture_buffer = 0, texel_buffer = 0, empty_vao = 0;
  Program shadow, shadow_cube, id, blur, composite;
  std::vector<ShadowMap> maps;
  GLuint id_fbo = 0, id_tex = 0, mask_tex = 0, depth_tex = 0;
  GLuint blur_fbo = 0, boundary_tex = 0;
  GLuint final_fbo = 0, final_tex = 0, final_depth = 0;
  GLuint visibility_tex = 0, cpu_tex = 0;
  GLuint queries[5] = {};
  Slot slots[2];
  std::size_t submitted = 0;  // frames submitted since the last finish()
  std::future<void> pending;  // the CPU pass of the last frame submitted (interleaved)

  Impl(const Scene& s, const HybridOptions& o, const Camera& view) : scene(s), options(o) {
    check_options(o);
    scene.validate("scene");
    if (scene.lights.size() > static_cast<std::size_t>(kMaxHybridLights))
      throw Error("--mode hybrid", "at most " + std::to_string(kMaxHybridLights) +
                                       " lights are supported, the scene has " +
                                       std::to_string(scene.lights.size()));
    FlatScene flat = flatten(scene);
    for (const Material& m : flat.materials)
      has_secondary = has_secondary || m.reflectivity > 0 || m.transparency > 0;
    const char* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
    GLint major = 0, minor = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &major);
    glGetIntegerv(GL_MINOR_VERSION, &minor);
    if (major * 10 + minor < 45)
      throw Error("--mode hybrid",
                  std::string("needs OpenGL 4.5, the context has ") + (version ? version : "none"));
    geometry = make_geometry(std::move(flat), nullptr, &view);
    lights = view_lights.size();
    upload_materials(geometry->flat);
    shadow = Program("scene.vert.glsl", "shadow.frag.glsl");
    shadow_cube = Program("scene.vert.glsl", "shadow.frag.glsl", {"shadow_cube.glsl"});
    id = Program("scene.vert.glsl", "id.frag.glsl", {"lights.glsl"});
    blur = Program("fullscreen.vert.glsl", "blur.frag.glsl");
    composite = Program("scene.vert.glsl", "composite.frag.glsl", {"lights.glsl", "texture.glsl"});
    make_targets();
    set_static_uniforms();
    glCreateQueries(GL_TIME_ELAPSED, 5, queries);
    gl::check_error("creating the hybrid renderer");
  }

  ~Impl() {
    glDeleteQueries(5, queries);
    GLuint textures[] = {id_tex,    mask_tex,    depth_tex,      boundary_tex,
                         final_tex, final_depth, visibility_tex, cpu_tex};
    glDeleteTextures(8, textures);
    GLuint fbos[] = {id_fbo, blur_fbo, final_fbo};
    glDeleteFramebuffers(3, fbos);
    for (ShadowMap& m : maps) {
      glDeleteTextures(1, &m.depth);
      glDeleteTextures(1, &m.flag);
      glDeleteFramebuffers(m.cube ? 6 : 1, m.fbo);
    }
    if (pending.valid()) pending.wait();
    GLuint buffers[] = {materials, texture_buffer, texel_buffer};
    glDeleteBuffers(3, buffers);
    glDeleteVertexArrays(1, &empty_vao);
  }

  // The hierarchy (built by `build`, or make_accel from the options) and the vertex buffer of
  // `flat`; the first geometry also decides the lights (fitted to `view` where the scene has
  // none of its own).
  std::shared_ptr<Geometry> make_geometry(
      FlatScene flat, const std::function<std::unique_ptr<Accel>(std::span<const Triangle>)>& build,
      const Camera* view = nullptr) {
    auto g = std::make_shared<Geometry>();
    g->flat = std::move(flat);
    g->accel = build ? build(g->flat.triangles)
                     : make_accel(options.accel, g->flat.triangles, options.build);
    if (view)
      view_lights =
          lights_for_view(scene, g->flat, *g->accel, *view, options.width, options.height);
    g->cpu =
        std::make_unique<gl::CpuPass>(scene, g->flat, view_lights, *g->accel, options.max_depth);
    g->bounds = bounds_of(g->flat.triangles);
    upload_vertices(*g);
    return g;
  }

  void upload_vertices(Geometry& g) {
    const FlatScene& flat = g.flat;
    std::vector<Vertex> vertices(flat.triangles.size() * 3);
    for (std::size_t t = 0; t < flat.triangles.size(); ++t) {
      const Triangle& tri = flat.triangles[t];
      const Vec3 ng = tri.geometric_normal();
      for (int k = 0; k < 3; ++k) {
        Vertex& v = vertices[t * 3 + k];
        const Vec3 p = tri.vertex(k), n = flat.vertex_normals[t][k];
        for (int c = 0; c < 3; ++c) {
          v.position[c] = p[c];
          v.normal[c] = n[c];
          v.geometric_normal[c] = ng[c];
        }
        v.material = flat.material[t];
        v.uv[0] = flat.uvs[t][k].x;
        v.uv[1] = flat.uvs[t][k].y;
      }
    }
    g.vertex_count = vertices.size();
    glCreateVertexArrays(1, &g.vao);
    const GLuint vao = g.vao;
    glCreateBuffers(1, &g.vbo);
    glNamedBufferStorage(g.vbo, static_cast<GLsizeiptr>(vertices.size() * sizeof(Vertex)),
                         vertices.data(), 0);
    glVertexArrayVertexBuffer(vao, 0, g.vbo, 0, sizeof(Vertex));
    for (GLuint a = 0; a < 3; ++a) {
      glEnableVertexArrayAttrib(vao, a);
      glVertexArrayAttribFormat(vao, a, 3, GL_FLOAT, GL_FALSE, a * GLuint{3 * sizeof(float)});
      glVertexArrayAttribBinding(vao, a, 0);
    }
    glEnableVertexArrayAttrib(vao, 3);
    glVertexArrayAttribIFormat(vao, 3, 1, GL_UNSIGNED_INT, offsetof(Vertex, material));
    glVertexArrayAttribBinding(vao, 3, 0);
    glEnableVertexArrayAttrib(vao, 4);
    glVertexArrayAttribFormat(vao, 4, 2, GL_FLOAT, GL_FALSE, offsetof(Vertex, uv));
    glVertexArrayAttribBinding(vao, 4, 0);
  }

  // The materials, and their textures as texel arrays that texture.glsl samples with the CPU's
  // arithmetic (core/texture.cpp), so that both renderers see the same colours.
  void upload_materials(const FlatScene& flat) {
    glCreateVertexArrays(1, &empty_vao);

    std::vector<MaterialGpu> mats;
    std::vector<TextureGpu> texture_info;
    std::vector<std::array<float, 4>> texel_data;
    std::vector<const Texture*> uploaded;
    for (const Material& m : flat.materials) {
      float texture = -1;
      if (const Texture* t = m.diffuse_texture.get()) {
        const auto it = std::find(uploaded.begin(), uploaded.end(), t);
        texture = static_cast<float>(it - uploaded.begin());
        if (it == uploaded.end()) {
          uploaded.push_back(t);
          texture_info.push_back(
              {t->width, t->height, static_cast<std::int32_t>(texel_data.size()),
               static_cast<std::int32_t>(t->wrap_u) | static_cast<std::int32_t>(t->wrap_v) << 2});
          for (const Vec3& c : t->texels) texel_data.push_back({c.x, c.y, c.z, 1});
        }
      }
      mats.push_back({{m.diffuse.x, m.diffuse.y, m.diffuse.z,
                       std::max(0.0f, 1.0f - m.reflectivity - m.transparency)},
                      {m.specular.x, m.specular.y, m.specular.z, m.shininess},
                      {m.transparency, texture, 0, 0},
                      {m.ambient.value_or(Vec3{0}).x, m.ambient.value_or(Vec3{0}).y,
                       m.ambient.value_or(Vec3{0}).z, m.ambient ? 1.0f : 0.0f}});
    }
    if (texture_info.empty()) texture_info.push_back({});  // buffers must not be empty
    if (texel_data.empty()) texel_data.push_back({});
    const auto make = [](GLuint& buffer, std::size_t bytes, const void* data) {
      glCreateBuffers(1, &buffer);
      glNamedBufferStorage(buffer, static_cast<GLsizeiptr>(bytes), data, 0);
    };
    make(materials, mats.size() * sizeof(MaterialGpu), mats.data());
    make(texture_buffer, texture_info.size() * sizeof(TextureGpu), texture_info.data());
    make(texel_buffer, texel_data.size() * sizeof(texel_data[0]), texel_data.data());
  }

  void make_targets() {
    const int w = options.width, h = options.height;
    for (const Light& light : view_lights) {
      ShadowMap m;
      m.cube = light.kind == Light::Kind::point;
      m.size = m.cube ? std::max(16, options.shadow_map_size / 2) : options.shadow_map_size;
      const GLenum target = m.cube ? GL_TEXTURE_CUBE_MAP : GL_TEXTURE_2D;
      glCreateTextures(target, 1, &m.depth);
      glTextureStorage2D(m.depth, 1, GL_DEPTH_COMPONENT32F, m.size, m.size);
      glTextureParameteri(m.depth, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
      glTextureParameteri(m.depth, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
      glCreateTextures(target, 1, &m.flag);
      glTextureStorage2D(m.flag, 1, GL_R8, m.size, m.size);
      for (GLuint t : {m.depth, m.flag}) {
        glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        glTextureParameteri(t, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(t, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        glTextureParameteri(t, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
      }
      const int faces = m.cube ? 6 : 1;
      glCreateFramebuffers(faces, m.fbo);
      for (int f = 0; f < faces; ++f) {
        if (m.cube) {
          glNamedFramebufferTextureLayer(m.fbo[f], GL_DEPTH_ATTACHMENT, m.depth, 0, f);
          glNamedFramebufferTextureLayer(m.fbo[f], GL_COLOR_ATTACHMENT0, m.flag, 0, f);
        } else {
          glNamedFramebufferTexture(m.fbo[f], GL_DEPTH_ATTACHMENT, m.depth, 0);
          glNamedFramebufferTexture(m.fbo[f], GL_COLOR_ATTACHMENT0, m.flag, 0);
        }
        check_fbo(m.fbo[f], "shadow map");
      }
      maps.push_back(m);
    }
    id_tex = gl::make_texture_2d(GL_R32UI, w, h);
    mask_tex = gl::make_texture_2d(GL_RGBA16F, w, h);
    depth_tex = gl::make_texture_2d(GL_DEPTH_COMPONENT32F, w, h);
    glCreateFramebuffers(1, &id_fbo);
    glNamedFramebufferTexture(id_fbo, GL_COLOR_ATTACHMENT0, id_tex, 0);
    glNamedFramebufferTexture(id_fbo, GL_COLOR_ATTACHMENT1, mask_tex, 0);
    glNamedFramebufferTexture(id_fbo, GL_DEPTH_ATTACHMENT, depth_tex, 0);
    const GLenum two[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glNamedFramebufferDrawBuffers(id_fbo, 2, two);
    check_fbo(id_fbo, "id buffer");
    boundary_tex = gl::make_texture_2d(GL_RGBA8, w, h);
    glCreateFramebuffers(1, &blur_fbo);
    glNamedFramebufferTexture(blur_fbo, GL_COLOR_ATTACHMENT0, boundary_tex, 0);
    check_fbo(blur_fbo, "blur buffer");
    final_tex = gl::make_texture_2d(GL_RGBA32F, w, h);
    final_depth = gl::make_texture_2d(GL_DEPTH_COMPONENT32F, w, h);
    glCreateFramebuffers(1, &final_fbo);
    glNamedFramebufferTexture(final_fbo, GL_COLOR_ATTACHMENT0, final_tex, 0);
    glNamedFramebufferTexture(final_fbo, GL_DEPTH_ATTACHMENT, final_depth, 0);
    check_fbo(final_fbo, "composite buffer");
    visibility_tex = gl::make_texture_2d(GL_RGBA32F, w, h);
    cpu_tex = gl::make_texture_2d(GL_RGBA32F, w, h);
  }

  static void check_fbo(GLuint fbo, const char* what) {
    if (glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error(std::string("OpenGL: ") + what, "framebuffer incomplete");
  }

  void set_static_uniforms() {
    for (const Program* p : {&id, &composite}) {
      const GLuint prog = p->id();
      glProgramUniform1i(prog, p->uniform("u_light_count"), static_cast<int>(lights));
      for (std::size_t i = 0; i < lights; ++i) {
        const Light& l = view_lights[i];
        const auto at = [&](const char* name) {
          return p->uniform((std::string(name) + "[" + std::to_string(i) + "]").c_str());
        };
        const Vec3 to_light = normalize(-l.direction), radiance = l.color * l.intensity;
        glProgramUniform1i(prog, at("u_light_kind"), l.kind == Light::Kind::point ? 0 : 1);
        glProgramUniform3f(prog, at("u_light_position"), l.position.x, l.position.y, l.position.z);
        glProgramUniform3f(prog, at("u_light_direction"), to_light.x, to_light.y, to_light.z);
        glProgramUniform3f(prog, at("u_light_radiance"), radiance.x, radiance.y, radiance.z);
        glProgramUniform1f(prog, at("u_light_falloff"), l.falloff ? 1.0f : 0.0f);
      }
    }
    for (int i = 0; i < kMaxHybridLights; ++i) {
      const auto at = [&](const char* name) {
        return id.uniform((std::string(name) + "[" + std::to_string(i) + "]").c_str());
      };
      glProgramUniform1i(id.id(), at("u_shadow_map"), kUnitMap + i);
      glProgramUniform1i(id.id(), at("u_shadow_flag"), kUnitFlag + i);
      glProgramUniform1i(id.id(), at("u_shadow_cube"), kUnitCube + i);
      glProgramUniform1i(id.id(), at("u_cube_flag"), kUnitCubeFlag + i);
    }
    glProgramUniform3f(composite.id(), composite.uniform("u_ambient"), scene.ambient.x,
                       scene.ambient.y, scene.ambient.z);
    glProgramUniform1i(composite.id(), composite.uniform("u_visibility"), 0);
    glProgramUniform1i(composite.id(), composite.uniform("u_cpu_color"), 1);
    glProgramUniform1i(blur.id(), blur.uniform("u_mask"), 0);
    glProgramUniform1i(blur.id(), blur.uniform("u_ids"), 1);
  }

  void draw_scene(const Geometry& g) {
    glBindVertexArray(g.vao);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, materials);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, texture_buffer);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, texel_buffer);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(g.vertex_count));
  }

  double query_ms(int pass) {
    GLuint64 ns = 0;
    glGetQueryObjectui64v(queries[pass], GL_QUERY_RESULT, &ns);
    return static_cast<double>(ns) * 1e-6;
  }

  // Pass 1: the shadow maps.
  void shadow_pass(const Camera& camera, const Geometry& g) {
    const Aabb& bounds = g.bounds;
    const float aspect = static_cast<float>(options.width) / static_cast<float>(options.height);
    const float texel = length(bounds.extent()) / static_cast<float>(options.shadow_map_size);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    for (std::size_t i = 0; i < lights; ++i) {
      ShadowMap& m = maps[i];
      const Light& light = view_lights[i];
      glViewport(0, 0, m.size, m.size);
      const Program& program = m.cube ? shadow_cube : shadow;
      program.use();
      std::array<glm::mat4, 6> matrices;
      if (m.cube) {
        float range = 0;
        for (int c = 0; c < 8; ++c) {
          const Vec3 corner{(c & 1) ? bounds.hi.x : bounds.lo.x,
                            (c & 2) ? bounds.hi.y : bounds.lo.y,
                            (c & 4) ? bounds.hi.z : bounds.lo.z};
          range = std::max(range, length(corner - light.position));
        }
        m.range = range * 1.01f + 1e-3f;
        matrices = gl::cube_face_matrices(light.position, m.range);
        glProgramUniform3f(program.id(), program.uniform("u_light_position"), light.position.x,
                           light.position.y, light.position.z);
        glProgramUniform1f(program.id(), program.uniform("u_range"), m.range);
        glDisable(GL_POLYGON_OFFSET_FILL);
      } else {
        m.matrix =
            gl::directional_light_matrix(camera, aspect, light.direction, bounds, options.lispsm);
        matrices[0] = m.matrix;
        glEnable(GL_POLYGON_OFFSET_FILL);
        glPolygonOffset(2.0f, 4.0f);
      }
      m.faces = matrices;
      for (int f = 0; f < (m.cube ? 6 : 1); ++f) {
        glBindFramebuffer(GL_FRAMEBUFFER, m.fbo[f]);
        const float clear_depth = 1, clear_flag[] = {0, 0, 0, 0};
        glClearNamedFramebufferfv(m.fbo[f], GL_DEPTH, 0, &clear_depth);
        glClearNamedFramebufferfv(m.fbo[f], GL_COLOR, 0, clear_flag);
        glProgramUniformMatrix4fv(program.id(), program.uniform("u_matrix"), 1, GL_FALSE,
                                  glm::value_ptr(matrices[f]));
        draw_scene(g);
      }
      glDisable(GL_POLYGON_OFFSET_FILL);
      const float offset = (m.cube ? 2.0f : 1.5f) * texel;
      m.normal_offset = offset;
      glProgramUniform1f(
          id.id(), id.uniform(("u_normal_offset[" + std::to_string(i) + "]").c_str()), offset);
      glProgramUniform1f(id.id(), id.uniform(("u_light_range[" + std::to_string(i) + "]").c_str()),
                         m.range);
      glProgramUniformMatrix4fv(id.id(),
                                id.uniform(("u_light_matrix[" + std::to_string(i) + "]").c_str()),
                                1, GL_FALSE, glm::value_ptr(m.matrix));
      glBindTextureUnit(static_cast<GLuint>((m.cube ? kUnitCube : kUnitMap) + static_cast<int>(i)),
                        m.depth);
      glBindTextureUnit(
          static_cast<GLuint>((m.cube ? kUnitCubeFlag : kUnitFlag) + static_cast<int>(i)), m.flag);
    }
  }

  // Passes 1-3 of a frame and the read-back into the slot.
  void gpu_front(const Camera& camera, Slot& slot) {
    const int w = options.width, h = options.height;
    slot.frame = HybridFrame{};
    slot.geometry = geometry;
    const Geometry& g = *geometry;
    slot.input.width = w;
    slot.input.height = h;
    slot.input.camera = camera;
    const PixelRect region = options.cpu_region.value_or(PixelRect{0, 0, w, h});
    slot.input.x0 = region.x0;
    slot.input.y0 = region.y0;
    slot.input.x1 = region.x1;
    slot.input.y1 = region.y1;

    glBeginQuery(GL_TIME_ELAPSED, queries[0]);
    shadow_pass(camera, g);
    glEndQuery(GL_TIME_ELAPSED);

    glBeginQuery(GL_TIME_ELAPSED, queries[1]);
    const glm::mat4 view_projection = gl::camera_matrix(camera, w, h, g.bounds);
    glViewport(0, 0, w, h);
    glBindFramebuffer(GL_FRAMEBUFFER, id_fbo);
    const GLuint zero_id[] = {0, 0, 0, 0};
    const float one[] = {1, 1, 1, 1}, clear_depth = 1;
    glClearNamedFramebufferuiv(id_fbo, GL_COLOR, 0, zero_id);
    glClearNamedFramebufferfv(id_fbo, GL_COLOR, 1, one);
    glClearNamedFramebufferfv(id_fbo, GL_DEPTH, 0, &clear_depth);
    id.use();
    glProgramUniformMatrix4fv(id.id(), id.uniform("u_matrix"), 1, GL_FALSE,
                              glm::value_ptr(view_projection));
    glProgramUniform3f(id.id(), id.uniform("u_eye"), camera.eye.x, camera.eye.y, camera.eye.z);
    glEnable(GL_DEPTH_TEST);
    draw_scene(g);
    glEndQuery(GL_TIME_ELAPSED);

    glBeginQuery(GL_TIME_ELAPSED, queries[2]);
    glBindFramebuffer(GL_FRAMEBUFFER, blur_fbo);
    glDisable(GL_DEPTH_TEST);
    blur.use();
    glProgramUniform1i(blur.id(), blur.uniform("u_radius"), options.blur_kernel / 2);
    glBindTextureUnit(0, mask_tex);
    glBindTextureUnit(1, id_tex);
    glBindVertexArray(empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glEndQuery(GL_TIME_ELAPSED);

    // Read back (rows flipped: the image's top row first).
    const std::size_t n = static_cast<std::size_t>(w) * h;
    std::vector<std::uint32_t> ids(n);
    std::vector<std::array<float, 4>> mask(n);
    std::vector<std::array<std::uint8_t, 4>> boundary(n);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glGetTextureImage(id_tex, 0, GL_RED_INTEGER, GL_UNSIGNED_INT, static_cast<GLsizei>(n * 4),
                      ids.data());
    glGetTextureImage(mask_tex, 0, GL_RGBA, GL_FLOAT, static_cast<GLsizei>(n * 16), mask.data());
    glGetTextureImage(boundary_tex, 0, GL_RGBA, GL_UNSIGNED_BYTE, static_cast<GLsizei>(n * 4),
                      boundary.data());
    slot.input.ids = flip(ids, w, h);
    slot.input.mask = flip(mask, w, h);
    slot.input.boundary = flip(boundary, w, h);
    read_light_maps(slot);
    for (int p = 0; p < 3; ++p) slot.frame.pass_ms[p] = query_ms(p);
    gl::check_error("passes 1-3");
  }

  // The shadow maps for the CPU's secondary shadow rays, when anything reflects or refracts.
  void read_light_maps(Slot& slot) {
    slot.input.maps.resize(0);
    if (!options.secondary || !options.map_secondary_shadows || !has_secondary) return;
    slot.input.maps.resize(maps.size());
    for (std::size_t i = 0; i < maps.size(); ++i) {
      const ShadowMap& m = maps[i];
      gl::LightMap& out = slot.input.maps[i];
      out.cube = m.cube;
      out.size = m.size;
      out.matrices = m.faces;
      out.position = view_lights[i].position;
      out.range = m.range;
      out.normal_offset = m.normal_offset;
      const std::size_t n = static_cast<std::size_t>(m.size) * m.size * (m.cube ? 6 : 1);
      out.depth.resize(n);
      out.flag.resize(n);
      glGetTextureImage(m.depth, 0, GL_DEPTH_COMPONENT, GL_FLOAT, static_cast<GLsizei>(n * 4),
                        out.depth.data());
      glGetTextureImage(m.flag, 0, GL_RED, GL_UNSIGNED_BYTE, static_cast<GLsizei>(n),
                        out.flag.data());
    }
  }

  template <typename T>
  static std::vector<T> flip(const std::vector<T>& v, int w, int h) {
    std::vector<T> out(v.size());
    for (int y = 0; y < h; ++y)
      std::copy_n(v.begin() + static_cast<std::ptrdiff_t>(h - 1 - y) * w, w,
                  out.begin() + static_cast<std::ptrdiff_t>(y) * w);
    return out;
  }

  void cpu_pass(Slot& slot) {
    slot.geometry->cpu->run(slot.input, options.secondary, options.refine_shadows, slot.output);
  }

  // Pass 5 and the read-back of the finished frame.
  void gpu_back(Slot& slot) {
    const int w = options.width, h = options.height;
    const std::size_t n = static_cast<std::size_t>(w) * h;
    const auto refined = flip(slot.output.refined, w, h);
    const auto color = flip(slot.output.color, w, h);
    glTextureSubImage2D(visibility_tex, 0, 0, 0, w, h, GL_RGBA, GL_FLOAT, refined.data());
    glTextureSubImage2D(cpu_tex, 0, 0, 0, w, h, GL_RGBA, GL_FLOAT, color.data());

    glBeginQuery(GL_TIME_ELAPSED, queries[4]);
    glViewport(0, 0, w, h);
    glBindFramebuffer(GL_FRAMEBUFFER, final_fbo);
    const float background[] = {scene.background.x, scene.background.y, scene.background.z, 1};
    const float clear_depth = 1;
    glClearNamedFramebufferfv(final_fbo, GL_COLOR, 0, background);
    glClearNamedFramebufferfv(final_fbo, GL_DEPTH, 0, &clear_depth);
    composite.use();
    const Camera& camera = slot.input.camera;
    glProgramUniformMatrix4fv(
        composite.id(), composite.uniform("u_matrix"), 1, GL_FALSE,
        glm::value_ptr(gl::camera_matrix(camera, w, h, slot.geometry->bounds)));
    glProgramUniform3f(composite.id(), composite.uniform("u_eye"), camera.eye.x, camera.eye.y,
                       camera.eye.z);
    glBindTextureUnit(0, visibility_tex);
    glBindTextureUnit(1, cpu_tex);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    draw_scene(*slot.geometry);
    glEndQuery(GL_TIME_ELAPSED);

    std::vector<std::array<float, 4>> pixels(n);
    glGetTextureImage(final_tex, 0, GL_RGBA, GL_FLOAT, static_cast<GLsizei>(n * 16), pixels.data());
    pixels = flip(pixels, w, h);
    HybridFrame& f = slot.frame;
    f.pass_ms[3] = slot.output.ms;
    f.pass_ms[4] = query_ms(4);
    f.image = Image(w, h);
    for (std::size_t i = 0; i < n; ++i)
      f.image.pixels[i] = Vec3{pixels[i][0], pixels[i][1], pixels[i][2]};
    f.cpu_rays = slot.output.rays;
    f.boundary_rays = slot.output.boundary_rays;
    f.map_answers = slot.output.map_answers;
    f.secondary_pixels = slot.output.secondary_pixels;
    f.boundary_pixels = slot.output.boundary_pixels;
    f.ids = slot.input.ids;
    f.mask = slot.input.mask;
    f.refined = slot.output.refined;
    gl::check_error("pass 5");
  }
};

HybridRenderer::HybridRenderer(const Scene& scene, const HybridOptions& options, const Camera& view)
    : impl_(std::make_unique<Impl>(scene, options, view)) {}
HybridRenderer::~HybridRenderer() = default;

std::optional<HybridFrame> HybridRenderer::submit(const Camera& camera) {
  Impl& r = *impl_;
  Slot& slot = r.slots[r.submitted % 2];
  r.gpu_front(camera, slot);
  ++r.submitted;
  if (!r.options.interleaved) {
    r.cpu_pass(slot);
    r.gpu_back(slot);
    return std::move(slot.frame);
  }
  std::optional<HybridFrame> previous_frame;
  if (r.pending.valid()) {
    r.pending.get();
    Slot& previous = r.slots[r.submitted % 2];  // (submitted - 2) % 2: the frame before
    r.gpu_back(previous);
    previous_frame = std::move(previous.frame);
  }
  r.pending = std::async(std::launch::async, [&r, &slot] { r.cpu_pass(slot); });
  return previous_frame;
}

std::optional<HybridFrame> HybridRenderer::finish() {
  Impl& r = *impl_;
  std::optional<HybridFrame> last;
  if (r.pending.valid()) {
    r.pending.get();
    Slot& slot = r.slots[(r.submitted - 1) % 2];
    r.gpu_back(slot);
    last = std::move(slot.frame);
  }
  r.submitted = 0;
  return last;
}

void HybridRenderer::render(std::span<const Camera> cameras,
                            const std::function<void(HybridFrame&&)>& done) {
  ThreadLimit limit(impl_->options.build.threads);
  for (const Camera& camera : cameras)
    if (auto frame = submit(camera)) done(std::move(*frame));
  if (auto frame = finish()) done(std::move(*frame));
}

void HybridRenderer::set_triangles(
    std::vector<Triangle> triangles,
    const std::function<std::unique_ptr<Accel>(std::span<const Triangle>)>& build) {
  Impl& r = *impl_;
  const FlatScene& old = r.geometry->flat;
  if (triangles.size() != old.triangles.size())
    throw Error("hybrid renderer", "a new frame must keep the triangle count (" +
                                       std::to_string(old.triangles.size()) + "), got " +
                                       std::to_string(triangles.size()));
  FlatScene flat;
  flat.materials = old.materials;
  flat.material = old.material;
  flat.uvs = old.uvs;
  flat.vertex_normals.resize(triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    Vec3 n = normalize(triangles[t].geometric_normal());
    if (!is_finite(n)) n = Vec3{0, 1, 0};
    flat.vertex_normals[t] = {n, n, n};
  }
  flat.triangles = std::move(triangles);
  r.geometry = r.make_geometry(std::move(flat), build);
}

HybridFrame HybridRenderer::render_one(const Camera& camera) {
  HybridFrame result;
  render(std::span<const Camera>(&camera, 1), [&](HybridFrame&& f) { result = std::move(f); });
  return result;
}

unsigned HybridRenderer::last_texture() const { return impl_->final_tex; }
const AccelStats& HybridRenderer::accel_stats() const { return impl_->geometry->accel->stats(); }
std::size_t HybridRenderer::light_count() const { return impl_->lights; }
const std::vector<Light>& HybridRenderer::lights() const { return impl_->view_lights; }
LightCoverage HybridRenderer::coverage(const Camera& camera) const {
  const Impl& r = *impl_;
  return light_coverage(r.view_lights, r.geometry->flat, *r.geometry->accel, camera,
                        r.options.width, r.options.height);
}
HybridOptions& HybridRenderer::options() { return impl_->options; }

HybridOptions HybridOptions::from(const RenderOptions& render) {
  HybridOptions o;
  o.width = render.width;
  o.height = render.height;
  o.max_depth = render.max_depth;
  o.accel = render.accel;
  o.build = render.build;
  return o;
}

RenderResult render_hybrid(const Scene& scene, const Camera& camera, const HybridOptions& options) {
  gl::EglContext context;
  HybridRenderer renderer(scene, options, camera);
  const Timer timer;
  HybridFrame frame = renderer.render_one(camera);
  RenderResult result;
  result.render_ms = timer.ms();
  result.image = std::move(frame.image);
  result.accel_stats = renderer.accel_stats();
  result.rays = frame.cpu_rays;
  result.cpu_ms = frame.pass_ms[3];
  result.lights = renderer.lights();
  result.coverage = renderer.coverage(camera);
  result.gl_renderer = gl::renderer_name();
  return result;
}

}  // namespace splitray
